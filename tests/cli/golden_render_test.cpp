// A golden hash of a WAV rendered through the full chain — band-pass, LQ feedforward, neural feedback in
// model mode, safety limiter — with the transducer simulated on the chained and on the bare drive. The
// hash was taken before the house refactor of issue #30 (models by concept, one copy of each kernel,
// the engine's step and regressor types); any change to what the chain or the plant computes, however
// small, changes it. If a change is meant to alter the numbers, say which and why, then pin the new hash.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <cstdio>
#include <string>

#include "dsp/wav_file.h"
#include "models/control/lq_feedforward.h"
#include "models/io/json_file.h"
#include "tests/engine/engine_test_models.h"
#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

using namespace testing_support;

// The rendered samples' float32 bit patterns (the WAV's own format), folded by 64-bit FNV-1a.
std::string fnv1a_of_columns(const dsp::Record& r) {
  std::uint64_t h = 14695981039346656037ULL;
  for (const Eigen::VectorXd& column : r.columns) {
    for (Eigen::Index k = 0; k < column.size(); ++k) {
      const auto bits = std::bit_cast<std::uint32_t>(static_cast<float>(column[k]));
      for (int byte = 0; byte < 4; ++byte) {
        h ^= (bits >> (8 * byte)) & 0xffU;
        h *= 1099511628211ULL;
      }
    }
  }
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(h));
  return text;
}

class CliGoldenRender : public CliTest {};

TEST_F(CliGoldenRender, TheFullChainRendersTheSameSamplesAsBeforeTheRefactor) {
  using engine::testing::example_feedback;
  using engine::testing::example_linear;
  models::write_json_file(dir_ / "ff.json", models::lq_feedforward_to_json(models::design_lq(example_linear(), {3.0, 20.0})));
  models::FeedbackStructure structure;
  structure.hidden = {5};
  models::write_json_file(dir_ / "fb.json", models::neural_feedback_to_json(example_feedback(structure, 2, 3, 0.3)));
  const fs::path chain = file("chain.json", R"({"format":"panelbass.chain/1","fs":3000,"block":64,
      "band_pass":{"low_hz":20,"high_hz":1200,"order":2},
      "feedforward":{"model":"ff.json"},"feedback":{"model":"fb.json","source":"model"},
      "limiter":{"knee":0.8}})");
  dsp::Record program;
  program.fs = 3000.0;
  program.add("program", engine::testing::uniform(6000, 0.3, 7));
  dsp::write_wav(dir_ / "in.wav", program, dsp::WavFormat::float32);

  const json r = expect_result(run("render --chain " + quoted(chain) + " --in " + quoted(dir_ / "in.wav") + " --out " +
                                   quoted(dir_ / "out.wav") + " --plant panel-exciter --seed 1"));
  ASSERT_EQ(r["columns"], json::array({"drive", "y", "y_bare", "y_desired"}));
  EXPECT_EQ(r["faults"], 0) << r;
  const dsp::Record out = dsp::read_wav(dir_ / "out.wav", {"drive", "y", "y_bare", "y_desired"});
  ASSERT_EQ(out.columns[0].size(), 6000);
  // The chain drives something: a hash of silence would pin nothing.
  EXPECT_GT(out.columns[0].cwiseAbs().maxCoeff(), 0.05);
  EXPECT_EQ(fnv1a_of_columns(out), "899c6557d1d10378") << r;
}

}  // namespace
}  // namespace panelbass

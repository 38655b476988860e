// `panelbass verify` as a user runs it: --help shows examples; an LQ feedforward verified on the virtual transducer
// gives one point per probe and level in which the transducer alone was driven to the chain's output level (within
// the 0.1 dB the search stops at) and the cut is the THDs' ratio in dB, both read from the point itself; a plant
// model is no feedforward (exit 1, naming the file and what the slot takes); a probe above fs/4 is bad usage naming
// --probes.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "models/io/json_file.h"
#include "models/linear/linear_model.h"
#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

using namespace testing_support;

// A resonance at 300 Hz (pole radius 0.9) with one sample of delay at 3000 Hz, as a linear model file.
void write_linear_model(const fs::path& path) {
  const double theta = 2.0 * std::numbers::pi * 300.0 / 3000.0;
  models::LinearModel m;
  m.tf.a = Eigen::Vector2d(-2.0 * 0.9 * std::cos(theta), 0.81);
  m.tf.b = Eigen::Vector2d(0.3, 0.2);
  m.tf.nk = 1;
  m.fs = 3000.0;
  m.method = "oe";
  models::write_json_file(path, models::linear_model_to_json(m));
}

TEST_F(CliTest, VerifyComparesTheChainWithTheTransducerAloneAtEqualOutput) {
  const RunResult help = run("verify --help");
  EXPECT_EQ(help.status, 0);
  EXPECT_TRUE(contains(help.out, "Examples")) << help.out;
  write_linear_model(dir_ / "lin.json");
  expect_result(run("design lq --model " + quoted(dir_ / "lin.json") + " --out " + quoted(dir_ / "ff.json")));
  const nlohmann::json result =
      expect_result(run("verify --ff " + quoted(dir_ / "ff.json") + " --plant panel-exciter --quiet-sensor --probes 80,160 "
                        "--levels 0.2 --settle-seconds 0.1 --analysis-seconds 0.2"));
  EXPECT_EQ(result.at("backend"), "virtual");
  ASSERT_EQ(result.at("points").size(), 2u);
  for (const nlohmann::json& p : result.at("points")) {
    if (!p.at("reachable").get<bool>()) continue;
    EXPECT_NEAR(20.0 * std::log10(p.at("plant_output_level").get<double>() / p.at("output_level").get<double>()), 0.0, 0.1);
    if (!p.at("thd_cut_db").is_null()) {
      EXPECT_NEAR(p.at("thd_cut_db").get<double>(),
                  20.0 * std::log10(p.at("plant").at("thd_pct").get<double>() / p.at("chain").at("thd_pct").get<double>()), 1e-9);
    }
  }
  const RunResult plant = run("verify --ff " + quoted(dir_ / "lin.json") + " --probes 80");
  expect_failure(plant);
  EXPECT_TRUE(contains(plant.err, "lin.json: ")) << plant.err;
  EXPECT_TRUE(contains(plant.err, "the feedforward slot takes lq_feedforward or mirror_filter")) << plant.err;
  const RunResult high = run("verify --ff " + quoted(dir_ / "ff.json") + " --probes 1000");
  expect_usage_error(high);
  EXPECT_TRUE(contains(high.err, "--probes: 1000 Hz is outside [10, fs/4 = 750] Hz")) << high.err;
}

}  // namespace
}  // namespace panelbass

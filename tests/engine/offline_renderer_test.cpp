// Offline rendering against numbers computed independently in the test: the stages evaluated
// directly (SosFilter, LinearModel::simulate, NarxModel::simulate, the limiter's curve), the same
// through WAV files, the plant's output against models::simulate, and bit-identity with the virtual
// backend running the same program.
#include "engine/offline_renderer.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "dsp/butterworth.h"
#include "dsp/wav_file.h"
#include "engine/virtual_backend.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "tests/engine/engine_test_models.h"
#include "tests/support/model_stages.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::engine {
namespace {

using testing::kFs;

// The chain of these tests: band-pass, a linear feedforward and a NARX feedback stage in model mode.
std::unique_ptr<Chain> full_chain(FeedbackSource source = FeedbackSource::model) {
  ChainOptions options;
  options.spec.max_block = 1024;
  auto chain = std::make_unique<Chain>(options);
  chain->feedforward().set_initial(std::make_unique<LinearStage>(testing::example_linear()));
  chain->feedback().set_initial(std::make_unique<NarxStage>(testing::example_narx(41, 8.0), source));
  return chain;
}

// The same chain evaluated stage by stage on the whole signal, without the engine.
Eigen::VectorXd direct_evaluation(const Eigen::VectorXd& program) {
  const Eigen::VectorXd band = dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs)).process(program);
  const Eigen::VectorXd ff = testing::example_linear().simulate(band);
  const Eigen::VectorXd fb = testing::example_narx(41, 8.0).simulate(ff);
  Eigen::VectorXd drive(fb.size());
  for (Eigen::Index k = 0; k < fb.size(); ++k) drive[k] = testing::reference_soft_limit(fb[k], 0.8);
  return drive;
}

TEST(OfflineRenderer, EqualsTheStagesEvaluatedDirectly) {
  const Eigen::VectorXd program = testing::uniform(4000, 0.6, 42);
  const Eigen::VectorXd expected = direct_evaluation(program);
  auto chain = full_chain();
  const Rendering r = render(*chain, program, {Samples{37}, {}, 1});
  EXPECT_EQ(r.measured.size(), 0);
  EXPECT_LE((r.drive - expected).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(chain->metrics().snapshot().faults, 0u);
  EXPECT_GT(expected.cwiseAbs().maxCoeff(), 0.8) << "the test should reach the limiter's knee";
}

TEST(OfflineRenderer, TheBlockLengthDoesNotChangeASingleBit) {
  const Eigen::VectorXd program = testing::uniform(3000, 0.6, 43);
  const Eigen::VectorXd reference = render(*full_chain(), program, {Samples{1}, {}, 1}).drive;
  for (int block : {7, 64, 1024}) {
    EXPECT_EQ(render(*full_chain(), program, {Samples{block}, {}, 1}).drive, reference) << block;
  }
  EXPECT_THROW(render(*full_chain(), program, {Samples{2048}, {}, 1}), std::invalid_argument);
}

class OfflineRendererFiles : public testing_support::ScratchDirectoryTest {};

TEST_F(OfflineRendererFiles, RendersAWavFileIntoAWavFile) {
  dsp::Record in;
  in.fs = kFs;
  in.add("program", testing::uniform(3000, 0.6, 44));
  dsp::write_wav(dir_ / "in.wav", in, dsp::WavFormat::float32);
  auto chain = full_chain();
  render_file(dir_ / "in.wav", "program", dir_ / "out.wav", *chain, {});
  // The input as the renderer read it (32-bit float), evaluated directly; the output is 32-bit float.
  const Eigen::VectorXd program = dsp::read_wav(dir_ / "in.wav", {"program"}).columns.front();
  const dsp::Record out = dsp::read_wav(dir_ / "out.wav", {"drive"});
  EXPECT_EQ(out.fs, kFs);
  EXPECT_LE((out.columns.front() - direct_evaluation(program)).cwiseAbs().maxCoeff(), 1e-7);
}

TEST_F(OfflineRendererFiles, RefusesAFileAtAnotherRate) {
  dsp::Record in;
  in.fs = 48000.0;
  in.add("program", testing::uniform(100, 0.5, 45));
  dsp::write_wav(dir_ / "in.wav", in, dsp::WavFormat::float32);
  auto chain = full_chain();
  EXPECT_THROW(render_file(dir_ / "in.wav", "program", dir_ / "out.wav", *chain, {}), std::invalid_argument);
}

TEST(OfflineRenderer, WithAPlantEqualsTheVirtualBackendBitForBit) {
  // Sensor mode: the NARX stage reads the plant's measured output sample by sample.
  const models::PlantConfig plant = models::plant_preset("panel-exciter");
  const Eigen::VectorXd program = testing::uniform(1500, 0.6, 46);
  const Rendering offline = render(*full_chain(FeedbackSource::sensor), program, {Samples{64}, plant, 7});

  // The plant's output is that of the plant simulated on its own from the rendered drive.
  EXPECT_EQ(models::simulate(plant, offline.drive, 7).y, offline.measured);

  auto chain = full_chain(FeedbackSource::sensor);
  Eigen::VectorXd drive(program.size()), measured(program.size());
  VirtualBackendOptions o;
  o.block = Samples{64};
  o.pacing = Pacing::as_fast_as_possible;
  o.program.assign(program.data(), program.data() + program.size());
  o.loop = false;
  o.plant = plant;
  o.noise_seed = 7;
  Eigen::Index at = 0;
  o.on_block = [&](const BlockView& b) {
    for (std::size_t k = 0; k < b.drive.size(); ++k, ++at) {
      drive[at] = b.drive[k];
      measured[at] = b.measured[k];
    }
  };
  VirtualBackend backend(*chain, std::move(o));
  backend.start();
  backend.wait();
  EXPECT_TRUE(backend.finished());
  ASSERT_EQ(at, program.size());
  EXPECT_EQ(drive, offline.drive);
  EXPECT_EQ(measured, offline.measured);
}

}  // namespace
}  // namespace panelbass::engine

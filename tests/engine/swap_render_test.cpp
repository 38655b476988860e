// Swaps in a rendered block sequence: the full chain closed over the virtual transducer, its feedforward
// and feedback slots swapped between blocks (linear ↔ LQ state space, NARX ↔ neural feedback, model and
// sensor mode, one install while a crossfade still runs), blocks of varying length. The figures pinned
// here are three random projections Σ w_k·drive(k) of the drive and one of the measured output, taken
// with the engine as it was before issue #30 moved the swap warm-up off the audio thread: the warm-up
// leaves what the chain computes unchanged.
#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "dsp/random.h"
#include "engine/chain.h"
#include "engine/closed_loop.h"
#include "engine/controller_stages.h"
#include "models/control/lq_feedforward.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "tests/engine/engine_test_models.h"
#include "tests/support/model_stages.h"

namespace panelbass::engine {
namespace {

using testing::kFs;

struct Rendered {
  std::vector<double> drive, measured;
};

// The control thread's installs, made between blocks: block index → what is installed.
void install_for_block(Chain& chain, int block) {
  models::FeedbackStructure structure;
  structure.hidden = {5};
  switch (block) {
    case 5:
      chain.feedback().install(std::make_unique<NarxStage>(testing::example_narx(3, 0.5), FeedbackSource::sensor));
      break;
    case 6:  // while the crossfade of block 5 may still run: waits until it ends
      chain.feedforward().install(std::make_unique<LinearStage>(testing::example_linear()));
      break;
    case 14: {
      const models::LqFeedforward ff = models::design_lq(testing::example_linear(), {1e-3, 20.0});
      chain.feedforward().install(std::make_unique<StateSpaceStage>(ff.controller(), kFs));
      break;
    }
    case 15:
      chain.feedback().install(std::make_unique<NeuralFeedbackStage>(
          testing::example_feedback(structure, 2, 3, 0.3), FeedbackSource::sensor));
      break;
    case 27:
      chain.feedback().install(std::make_unique<NeuralFeedbackStage>(
          testing::example_feedback(structure, 4, 5, 0.5), FeedbackSource::model));
      break;
    case 33:
      chain.feedback().install(std::make_unique<NarxStage>(testing::example_narx(6, 0.6), FeedbackSource::model));
      break;
    default:
      break;
  }
}

Rendered render() {
  ChainOptions options;
  options.spec = {kFs, 96};
  Chain chain(options);
  chain.feedforward().set_initial(std::make_unique<LinearStage>(
      testing::resonant_linear(0.9, 0.3, Eigen::Vector2d(0.05, 0.02), 1)));
  chain.feedback().set_initial(std::make_unique<NarxStage>(testing::example_narx(1, 0.7), FeedbackSource::sensor));
  models::VirtualTransducer plant(models::plant_preset("panel-exciter"), 1);
  const Eigen::VectorXd program = testing::uniform(4000, 0.4, 11);
  Rendered out{std::vector<double>(program.size()), std::vector<double>(program.size())};
  const int lengths[] = {64, 17, 96, 1, 40};
  std::size_t pos = 0;
  for (int block = 0; pos < out.drive.size(); ++block) {
    install_for_block(chain, block);
    const std::size_t n = std::min<std::size_t>(lengths[block % 5], out.drive.size() - pos);
    process_closed_loop(chain, plant, {program.data() + pos, n}, {out.drive.data() + pos, n},
                        {out.measured.data() + pos, n});
    chain.collect_retired();
    pos += n;
  }
  return out;
}

double projection(const std::vector<double>& x, std::uint64_t seed) {
  dsp::Rng rng(seed);
  double sum = 0.0;
  for (double v : x) sum += rng.uniform(-1.0, 1.0) * v;
  return sum;
}

TEST(SwapRender, TheChainComputesWhatItDidBeforeTheWarmUpLeftTheAudioThread) {
  const Rendered r = render();
  const double p[] = {projection(r.drive, 1), projection(r.drive, 2), projection(r.drive, 3),
                      projection(r.measured, 4)};
  // Taken with the engine before issue #30 (main at 19b86ec, its engine and models libraries).
  const double before[] = {-1.8607031479606433, 13.07643265368873, -1.5051568279040861, 2.740898787287783};
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(p[i], before[i], 1e-12 * (1.0 + std::abs(before[i]))) << i;
}

TEST(SwapRender, RenderingTwiceGivesTheSameSamples) {
  const Rendered a = render();
  const Rendered b = render();
  EXPECT_EQ(a.drive, b.drive);
  EXPECT_EQ(a.measured, b.measured);
}

}  // namespace
}  // namespace panelbass::engine

// Model slots: take-over only at a block boundary, the crossfade (linear, and slowed where it would
// add a step), warm-up from history (the swap of a model for an identical one is invisible), bypass
// ramps, and who frees what: a stage replaced while pending is freed by install(), a retired one only
// by collect_retired() on the control thread.
#include "engine/model_slot.h"

#include <gtest/gtest.h>

#include <memory>
#include <stdexcept>

#include "tests/engine/engine_test_models.h"
#include "tests/support/model_stages.h"

namespace panelbass::engine {
namespace {

using testing::kFs;

/// y = gain·x; counts its destruction in `*destroyed`.
class GainStage final : public Stage {
 public:
  GainStage(double gain, int* destroyed = nullptr) : gain_(gain), destroyed_(destroyed) {}
  ~GainStage() override {
    if (destroyed_ != nullptr) ++*destroyed_;
  }
  void prepare(const ProcessSpec&) override {}
  double process(double x) noexcept override { return gain_ * x; }
  void reset() noexcept override {}

 private:
  double gain_;
  int* destroyed_;
};

SlotOptions options(int crossfade, int history) { return {Samples{crossfade}, Samples{history}}; }

TEST(ModelSlot, AnEmptySlotPassesItsInputThrough) {
  Metrics metrics;
  ModelSlot slot({kFs, 64}, options(8, 16), metrics, 1);
  slot.begin_block();
  EXPECT_EQ(slot.process(0.3), 0.3);
}

TEST(ModelSlot, TakesOverOnlyAtABlockBoundaryThenCrossfadesLinearly) {
  Metrics metrics;
  ModelSlot slot({kFs, 64}, options(8, 16), metrics, 1);
  slot.set_initial(std::make_unique<GainStage>(1.0));
  // A loud alternating input: each stage's own steps are ≈ 2, so the fade never needs slowing down.
  auto x = [](int k) { return (k % 2 == 0 ? 1.0 : -1.0) * (1.0 + 0.01 * k); };
  int k = 0;
  slot.begin_block();
  for (; k < 10; ++k) EXPECT_EQ(slot.process(x(k)), x(k));
  auto doubling = std::make_unique<GainStage>(2.0);
  doubling->set_id(7);
  slot.install(std::move(doubling));
  for (; k < 13; ++k) EXPECT_EQ(slot.process(x(k)), x(k)) << "taken over before the block boundary";
  EXPECT_FALSE(slot.idle());
  slot.begin_block();
  // y = (1 − g)·x + g·2x with g = j/8 on the j-th sample of the fade
  for (int j = 1; j <= 8; ++j, ++k) EXPECT_DOUBLE_EQ(slot.process(x(k)), x(k) + j / 8.0 * x(k)) << j;
  EXPECT_TRUE(slot.idle());
  EXPECT_EQ(slot.process(x(k)), 2.0 * x(k));
  EXPECT_EQ(metrics.snapshot().swaps, 1u);
  EXPECT_EQ(metrics.snapshot().active_ids[1], 7u);
}

TEST(ModelSlot, AFadeWithNoStepToHideBehindRunsAtAQuarterOfItsSpeed) {
  Metrics metrics;
  ModelSlot slot({kFs, 64}, options(8, 4), metrics, 1);
  slot.set_initial(std::make_unique<GainStage>(1.0));
  slot.begin_block();
  for (int k = 0; k < 300; ++k) slot.process(1.0);  // the output's recent steps decay to nothing
  slot.install(std::make_unique<GainStage>(2.0));
  slot.begin_block();
  // Both stages are constant: any fade adds a step, so it goes at the minimum, 1/(4·8) per sample.
  for (int j = 1; j <= 32; ++j) EXPECT_DOUBLE_EQ(slot.process(1.0), 1.0 + j / 32.0) << j;
  EXPECT_TRUE(slot.idle());
}

TEST(ModelSlot, AStageReplacedWhilePendingIsFreedByInstall) {
  Metrics metrics;
  int destroyed = 0;
  ModelSlot slot({kFs, 64}, options(8, 16), metrics, 1);
  slot.install(std::make_unique<GainStage>(2.0, &destroyed));
  slot.install(std::make_unique<GainStage>(3.0, &destroyed));
  EXPECT_EQ(destroyed, 1);
  slot.begin_block();
  for (int k = 0; k < 8; ++k) slot.process(1.0);
  EXPECT_EQ(slot.process(1.0), 3.0);
}

TEST(ModelSlot, ARetiredStageIsFreedOnlyByTheControlThread) {
  Metrics metrics;
  int destroyed = 0;
  {
    ModelSlot slot({kFs, 64}, options(4, 16), metrics, 1);
    slot.set_initial(std::make_unique<GainStage>(1.0, &destroyed));
    slot.install(std::make_unique<GainStage>(2.0, &destroyed));
    slot.begin_block();
    for (int k = 0; k < 10; ++k) slot.process(1.0);
    EXPECT_TRUE(slot.idle());
    EXPECT_EQ(destroyed, 0) << "the audio thread must not free";
    EXPECT_EQ(slot.collect_retired(), 1u);
    EXPECT_EQ(destroyed, 1);
  }
  EXPECT_EQ(destroyed, 2);
}

TEST(ModelSlot, ANewStageWarmedFromHistoryTakesOverInvisibly) {
  const models::LinearModel m = testing::example_linear();
  const Eigen::VectorXd u = testing::uniform(1000, 0.5, 21);
  const Eigen::VectorXd expected = m.simulate(u);
  // Swap the model for an identical one at sample 500, warmed from 600 samples of history (the
  // slowest pole forgets the start by 0.95^600 ≈ 4e-14) or not warmed at all.
  auto run = [&](int history) {
    Metrics metrics;
    ModelSlot slot({kFs, 64}, options(16, history), metrics, 1);
    slot.set_initial(std::make_unique<LinearStage>(m));
    Eigen::VectorXd y(u.size());
    for (Eigen::Index k = 0; k < u.size(); ++k) {
      if (k == 500) slot.install(std::make_unique<LinearStage>(m));
      if (k % 50 == 0) slot.begin_block();
      y[k] = slot.process(u[k]);
    }
    return y;
  };
  const double scale = expected.cwiseAbs().maxCoeff();
  EXPECT_LE((run(600) - expected).cwiseAbs().maxCoeff(), 1e-12 * scale);
  EXPECT_GT((run(0) - expected).cwiseAbs().maxCoeff(), 1e-2 * scale) << "a cold start should be visible";
}

TEST(ModelSlot, AStageThatWaitedBehindACrossfadeCatchesUpOverBlocksAndStillTakesOverInvisibly) {
  const models::LinearModel m = testing::example_linear();
  const Eigen::VectorXd u = testing::uniform(3000, 0.5, 24);
  const Eigen::VectorXd expected = m.simulate(u);
  Metrics metrics;
  // A 300-sample crossfade: the second stage, installed 5 samples after the first, waits 6 blocks of 50,
  // so its snapshot is 295 samples stale; it catches up 62 samples a block (12 more than come in) until
  // a block or less is left, then crossfades.
  ModelSlot slot({kFs, 64}, options(300, 600), metrics, 1);
  slot.set_initial(std::make_unique<LinearStage>(m));
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    if (k == 700 || k == 705) slot.install(std::make_unique<LinearStage>(m));
    if (k % 50 == 0) slot.begin_block();
    y[k] = slot.process(u[k]);
  }
  EXPECT_EQ(metrics.snapshot().swaps, 2u);
  EXPECT_TRUE(slot.idle());
  EXPECT_LE((y - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
}

TEST(ModelSlot, AStageWhoseMissedSamplesLeftTheHistoryStartsAfreshFromWhatIsKept) {
  // History of 40 samples, a stage waiting 300 samples behind a crossfade: what it missed is gone, so it
  // restarts from the 40 samples kept and catches up from there; a NARX model in sensor mode forgets
  // everything older than na, nb + nk samples, so its output is still the one-step prediction.
  const models::NarxModel m = testing::example_narx(9);
  const Eigen::VectorXd u = testing::uniform(1200, 1.0, 25);
  const Eigen::VectorXd measured = testing::uniform(1200, 0.5, 26);
  const Eigen::VectorXd expected = m.predict(u, measured);
  Metrics metrics;
  ModelSlot slot({kFs, 64}, options(300, 40), metrics, 2);
  slot.set_initial(std::make_unique<NarxStage>(m, FeedbackSource::sensor));
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    if (k == 96 || k == 100) slot.install(std::make_unique<NarxStage>(m, FeedbackSource::sensor));
    if (k % 32 == 0) slot.begin_block();
    y[k] = slot.process(u[k]);
    slot.observe(measured[k]);
  }
  EXPECT_EQ(metrics.snapshot().swaps, 2u);
  EXPECT_TRUE(slot.idle());
  EXPECT_LE((y - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
}

TEST(ModelSlot, ASensorModeStageIsWarmedFromTheMeasuredHistoryToo) {
  const models::NarxModel m = testing::example_narx(9);
  const Eigen::VectorXd u = testing::uniform(600, 1.0, 22);
  const Eigen::VectorXd measured = testing::uniform(600, 0.5, 23);
  const Eigen::VectorXd expected = m.predict(u, measured);
  Metrics metrics;
  ModelSlot slot({kFs, 64}, options(16, 32), metrics, 2);
  slot.set_initial(std::make_unique<NarxStage>(m, FeedbackSource::sensor));
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    if (k == 300) slot.install(std::make_unique<NarxStage>(m, FeedbackSource::sensor));
    if (k % 32 == 0) slot.begin_block();
    y[k] = slot.process(u[k]);
    slot.observe(measured[k]);
  }
  EXPECT_EQ(metrics.snapshot().swaps, 1u);
  EXPECT_LE((y - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
}

TEST(ModelSlot, BypassRampsToTheInputAndBack) {
  Metrics metrics;
  ModelSlot slot({kFs, 64}, options(4, 16), metrics, 1);
  slot.set_initial(std::make_unique<GainStage>(2.0));
  slot.begin_block();
  EXPECT_EQ(slot.process(1.0), 2.0);
  slot.set_bypassed(true);
  slot.begin_block();
  for (double expected : {1.75, 1.5, 1.25, 1.0, 1.0}) EXPECT_DOUBLE_EQ(slot.process(1.0), expected);
  slot.set_bypassed(false);
  slot.begin_block();
  for (double expected : {1.25, 1.5, 1.75, 2.0, 2.0}) EXPECT_DOUBLE_EQ(slot.process(1.0), expected);
}

TEST(ModelSlot, InstallPublishesNothingWhenPrepareFails) {
  Metrics metrics;
  ModelSlot slot({48000.0, 64}, options(4, 16), metrics, 1);
  EXPECT_THROW(slot.install(std::make_unique<LinearStage>(testing::example_linear())), std::invalid_argument);
  EXPECT_TRUE(slot.idle());
  EXPECT_THROW(slot.install(nullptr), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::engine

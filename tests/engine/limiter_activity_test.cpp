// The chain's limiter activity in its metrics — samples compressed above the knee, samples that asked for
// full scale or more, the largest drive asked for — counted against the band-pass and a gain evaluated
// directly (dsp's Butterworth band-pass filter, then the gain), block sizes varied.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "dsp/butterworth.h"
#include "engine/chain.h"
#include "engine/controller_stages.h"
#include "tests/engine/engine_test_models.h"
#include "tests/support/model_stages.h"

namespace panelbass::engine {
namespace {

using testing::kFs;

/// `program` through `chain` in blocks of 1 to 109 samples.
void run_in_varied_blocks(Chain& chain, const Eigen::VectorXd& program) {
  std::vector<double> drive(static_cast<std::size_t>(program.size()));
  for (Eigen::Index pos = 0, block = 1; pos < program.size(); pos += block, block = block % 97 + 13) {
    const Eigen::Index n = std::min(block, program.size() - pos);
    chain.process_block({program.data() + pos, static_cast<std::size_t>(n)},
                        {drive.data() + pos, static_cast<std::size_t>(n)});
  }
}

TEST(ChainLimiterActivity, CountsWhatTheDirectEvaluationAsksOfTheLimiter) {
  const double gain = 4.0;
  const Eigen::VectorXd program = testing::uniform(3000, 0.3, 41);
  const Eigen::VectorXd asked =
      gain * dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs)).process(program);
  ChainOptions options;  // knee 0.8, max_pinned 300 samples: noise never pins
  std::uint64_t limited = 0, over_range = 0;
  for (Eigen::Index k = 0; k < asked.size(); ++k) {
    limited += std::abs(asked[k]) > options.limiter.knee ? 1 : 0;
    over_range += std::abs(asked[k]) >= 1.0 ? 1 : 0;
  }
  ASSERT_GT(over_range, 10u);  // the case is one that asks for more than full scale
  ASSERT_GT(limited, over_range);

  Chain chain(options);
  chain.feedforward().set_initial(std::make_unique<LinearStage>(testing::gain_model(gain)));
  run_in_varied_blocks(chain, program);
  const MetricsSnapshot m = chain.metrics().snapshot();
  EXPECT_EQ(m.faults, 0u);
  EXPECT_EQ(m.limited_samples, limited);
  EXPECT_EQ(m.over_range_samples, over_range);
  EXPECT_NEAR(m.peak_demand, asked.cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_GT(m.peak_demand, 1.0);
  EXPECT_LT(m.peak_drive, 1.0);  // what the limiter let through
}

TEST(ChainLimiterActivity, AProgramWithinTheKneeIsNeverLimited) {
  Chain chain(ChainOptions{});
  const Eigen::VectorXd program = testing::uniform(2000, 0.2, 42);
  std::vector<double> drive(2000);
  for (std::size_t pos = 0; pos < 2000; pos += 1000) chain.process_block({program.data() + pos, 1000}, {drive.data() + pos, 1000});
  const MetricsSnapshot m = chain.metrics().snapshot();
  EXPECT_EQ(m.limited_samples, 0u);
  EXPECT_EQ(m.over_range_samples, 0u);
  const Eigen::VectorXd band = dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs)).process(program);
  EXPECT_NEAR(m.peak_demand, band.cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_DOUBLE_EQ(m.peak_drive, m.peak_demand);  // below the knee the limiter passes the drive unchanged
}

TEST(ChainLimiterActivity, WhatANeuralFeedbackStageAskedBeforeItsOwnSoftLimitCounts) {
  // N1 = 0 (zero weights): the stage's unlimited output u + N1 is its input, the band-passed program × 3, which
  // asks for more than full scale; its soft limit keeps the drive below 1, so only the stage can tell
  const double gain = 3.0;
  const Eigen::VectorXd program = testing::uniform(3000, 0.3, 43);
  const Eigen::VectorXd asked =
      gain * dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs)).process(program);
  const auto over_range = static_cast<std::uint64_t>((asked.array().abs() >= 1.0).count());
  ASSERT_GT(over_range, 10u);
  for (const FeedbackSource source : {FeedbackSource::model, FeedbackSource::sensor}) {
    Chain chain(ChainOptions{});
    chain.feedforward().set_initial(std::make_unique<LinearStage>(testing::gain_model(gain)));
    chain.feedback().set_initial(std::make_unique<NeuralFeedbackStage>(
        models::NeuralFeedback::with_structure(models::FeedbackStructure{}, testing::example_narx(5)), source));
    run_in_varied_blocks(chain, program);
    const MetricsSnapshot m = chain.metrics().snapshot();
    EXPECT_FALSE(m.in_fault);  // (in sensor mode the silent sensor is reported, nothing bypassed)
    EXPECT_EQ(m.over_range_samples, over_range);
    EXPECT_NEAR(m.peak_demand, asked.cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT(m.peak_drive, 1.0);
  }
  // below full scale nothing counts
  Chain quiet(ChainOptions{});
  quiet.feedback().set_initial(std::make_unique<NeuralFeedbackStage>(
      models::NeuralFeedback::with_structure(models::FeedbackStructure{}, testing::example_narx(5)), FeedbackSource::model));
  std::vector<double> drive(3000);
  quiet.process_block({program.data(), 3000}, drive);
  EXPECT_EQ(quiet.metrics().snapshot().over_range_samples, 0u);
}

}  // namespace
}  // namespace panelbass::engine

// The chain's limiter activity in its metrics — samples compressed above the knee, samples that asked for
// full scale or more, the largest drive asked for — counted against the band-pass and a gain evaluated
// directly (dsp's Butterworth band-pass filter, then the gain), block sizes varied.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>

#include "dsp/butterworth.h"
#include "engine/chain.h"
#include "tests/engine/engine_test_models.h"

namespace panelbass::engine {
namespace {

using testing::kFs;

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
  std::vector<double> drive(static_cast<std::size_t>(program.size()));
  for (Eigen::Index pos = 0, block = 1; pos < program.size(); pos += block, block = block % 97 + 13) {
    const Eigen::Index n = std::min(block, program.size() - pos);
    chain.process_block({program.data() + pos, static_cast<std::size_t>(n)},
                        {drive.data() + pos, static_cast<std::size_t>(n)});
  }
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

}  // namespace
}  // namespace panelbass::engine

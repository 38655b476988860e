// j_percent ([2A] J = Σ (y_model − y)² / Σ y², in percent), its weighted and energy-ratio forms, and jc_percent ([2C]) against hand computations and their
// boundary cases: a perfect model, a zero model, a skipped prefix, and every documented error.
#include "models/validation/performance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "dsp/excitation.h"
#include "tests/support/expect_error.h"
#include "tests/support/vectors.h"

namespace panelbass::models {
namespace {

using testing_support::vec;

TEST(PerformanceTest, MatchesHandComputation) {
  // errors 0.5, 0, −1, 2 → Σe² = 0.25 + 0 + 1 + 4 = 5.25; Σy² = 1 + 4 + 9 + 16 = 30.
  const Eigen::VectorXd y = vec({1.0, 2.0, 3.0, 4.0});
  const Eigen::VectorXd ym = vec({1.5, 2.0, 2.0, 6.0});
  EXPECT_NEAR(j_percent(ym, y), 100.0 * 5.25 / 30.0, 1e-12);
}

TEST(PerformanceTest, MatchesPlainLoopOnRandomData) {
  const Eigen::VectorXd y = dsp::uniform_noise(500, 1.0, 11);
  const Eigen::VectorXd ym = y + 0.3 * dsp::uniform_noise(500, 1.0, 12);
  double num = 0.0, den = 0.0;
  for (Eigen::Index k = 0; k < y.size(); ++k) {
    num += (ym[k] - y[k]) * (ym[k] - y[k]);
    den += y[k] * y[k];
  }
  EXPECT_NEAR(j_percent(ym, y), 100.0 * num / den, 1e-10);
}

TEST(PerformanceTest, PerfectModelGivesZero) {
  const Eigen::VectorXd y = dsp::uniform_noise(200, 0.7, 3);
  EXPECT_EQ(j_percent(y, y), 0.0);
}

TEST(PerformanceTest, ZeroModelGives100) {
  const Eigen::VectorXd y = dsp::uniform_noise(200, 0.7, 4);
  EXPECT_NEAR(j_percent(Eigen::VectorXd::Zero(200), y), 100.0, 1e-12);
}

TEST(PerformanceTest, ScaledModelGivesClosedForm) {
  // y_model = c·y → J = (c − 1)² · 100, whatever y is.
  const Eigen::VectorXd y = dsp::uniform_noise(300, 1.0, 5);
  EXPECT_NEAR(j_percent(0.8 * y, y), 100.0 * 0.04, 1e-10);
  EXPECT_NEAR(j_percent(1.5 * y, y), 100.0 * 0.25, 1e-10);
}

TEST(PerformanceTest, StartSkipsSamples) {
  // From start = 2: errors −1, 2 → Σe² = 5; Σy² = 9 + 16 = 25 → 20 %.
  const Eigen::VectorXd y = vec({1.0, 2.0, 3.0, 4.0});
  const Eigen::VectorXd ym = vec({1.5, 2.0, 2.0, 6.0});
  EXPECT_NEAR(j_percent(ym, y, 2), 20.0, 1e-12);
  // The skipped samples do not matter at all, however large their error.
  Eigen::VectorXd ym2 = ym;
  ym2[0] = 1e6;
  ym2[1] = -1e6;
  EXPECT_EQ(j_percent(ym2, y, 2), j_percent(ym, y, 2));
  // The last sample alone: error 2, y = 4 → 25 %.
  EXPECT_NEAR(j_percent(ym, y, 3), 25.0, 1e-12);
}

TEST(PerformanceTest, ThrowsOnUnequalLengths) {
  EXPECT_THROW(j_percent(Eigen::VectorXd::Ones(4), Eigen::VectorXd::Ones(5)), std::invalid_argument);
  EXPECT_THROW(j_percent(Eigen::VectorXd::Ones(5), Eigen::VectorXd::Ones(4)), std::invalid_argument);
}

TEST(PerformanceTest, ThrowsOnZeroEnergyOutput) {
  EXPECT_THROW(j_percent(Eigen::VectorXd::Ones(4), Eigen::VectorXd::Zero(4)), std::invalid_argument);
  // Energy only before `start` is no energy in the range.
  const Eigen::VectorXd y = vec({1.0, 2.0, 0.0, 0.0});
  EXPECT_THROW(j_percent(Eigen::VectorXd::Ones(4), y, 2), std::invalid_argument);
}

TEST(PerformanceTest, ThrowsOnNonFiniteModelOutput) {
  const Eigen::VectorXd y = vec({1.0, 2.0, 3.0, 4.0});
  Eigen::VectorXd ym = y;
  ym[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(j_percent(ym, y), std::invalid_argument);
  ym[2] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(j_percent(ym, y), std::invalid_argument);
  ym[2] = -std::numeric_limits<double>::infinity();
  EXPECT_THROW(j_percent(ym, y), std::invalid_argument);
}

TEST(PerformanceTest, ThrowsOnEmptyRange) {
  const Eigen::VectorXd y = vec({1.0, 2.0, 3.0});
  EXPECT_THROW(j_percent(y, y, 3), std::invalid_argument);
  EXPECT_THROW(j_percent(y, y, 10), std::invalid_argument);
  EXPECT_THROW(j_percent(y, y, -1), std::invalid_argument);
  EXPECT_THROW(j_percent(Eigen::VectorXd(), Eigen::VectorXd()), std::invalid_argument);
}

TEST(PerformanceTest, JcIsTheThesisRatio) {
  Eigen::VectorXd d(4), y(4);
  d << 1, -2, 2, 0;
  y << 1, -1, 2, 1;
  EXPECT_DOUBLE_EQ(jc_percent(y, d), 100.0 * 2.0 / 9.0);
  EXPECT_DOUBLE_EQ(jc_percent(y, d, 2), 100.0 * 1.0 / 4.0);
  // weighted: Σ w·(d − y)² / Σ w·d² = (0 + 3·1 + 0 + 0.5·1) / (1 + 3·4 + 2·4 + 0)
  Eigen::VectorXd w(4);
  w << 1, 3, 2, 0.5;
  EXPECT_DOUBLE_EQ(jc_percent(y, d, 0, w), 100.0 * 3.5 / 21.0);
  testing_support::expect_invalid([&] { jc_percent(y, d, 0, Eigen::VectorXd::Ones(3)); }, "3 weights");
  testing_support::expect_invalid([&] { jc_percent(y, Eigen::VectorXd::Zero(4)); }, "the desired output has no energy");
}

TEST(PerformanceTest, WeightedJIsTheRatioOfWeightedEnergies) {
  // errors 0.5, 0, −1, 2 and weights 2, 1, 0, 0.5: Σ w·e² = 0.5 + 0 + 0 + 2 = 2.5; Σ w·y² = 2 + 4 + 0 + 8 = 14.
  const Eigen::VectorXd y = vec({1.0, 2.0, 3.0, 4.0});
  const Eigen::VectorXd ym = vec({1.5, 2.0, 2.0, 6.0});
  const Eigen::VectorXd w = vec({2.0, 1.0, 0.0, 0.5});
  EXPECT_NEAR(j_weighted_percent(ym, y, w), 100.0 * 2.5 / 14.0, 1e-12);
  // Equal weights are the unweighted J.
  EXPECT_NEAR(j_weighted_percent(ym, y, Eigen::VectorXd::Constant(4, 3.0)), j_percent(ym, y), 1e-12);
  // From start = 2: (0 + 0.5·4) / (0 + 0.5·16).
  EXPECT_NEAR(j_weighted_percent(ym, y, w, 2), 100.0 * 2.0 / 8.0, 1e-12);
  testing_support::expect_invalid([&] { j_weighted_percent(ym, y, Eigen::VectorXd::Ones(3)); }, "weights 3");
  testing_support::expect_invalid([&] { j_weighted_percent(ym, y, vec({1.0, -1.0, 1.0, 1.0})); }, "negative weight");
}

// The silent output, one rule for every J: std::invalid_argument naming the channel, never 0, NaN or +∞.
TEST(PerformanceTest, ASilentOutputIsRefusedNamingItsChannel) {
  EXPECT_DOUBLE_EQ(j_ratio_percent(1.0, 4.0), 25.0);
  testing_support::expect_invalid([&] { j_ratio_percent(1.0, 0.0, "output y2"); }, "J: output y2 has no energy");
  testing_support::expect_invalid([&] { j_ratio_percent(0.0, 0.0); }, "the measured output has no energy");
  testing_support::expect_invalid([&] { j_ratio_percent(std::nan(""), 1.0); }, "not finite");
  testing_support::expect_invalid([&] { j_percent(Eigen::VectorXd::Zero(4), Eigen::VectorXd::Zero(4), 0, "the current"); },
                                  "J: the current has no energy");
  testing_support::expect_invalid(
      [&] { j_weighted_percent(Eigen::VectorXd::Ones(4), Eigen::VectorXd::Ones(4), Eigen::VectorXd::Zero(4)); },
      "the weighted output has no energy");
}

}  // namespace
}  // namespace panelbass::models

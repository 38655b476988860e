#include "dsp/period.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dsp/excitation.h"

namespace panelbass::dsp {
namespace {

Eigen::VectorXd repeated(const Eigen::VectorXd& period, int times) {
  Eigen::VectorXd x(period.size() * times);
  for (int i = 0; i < times; ++i) x.segment(i * period.size(), period.size()) = period;
  return x;
}

TEST(FindPeriod, ARepeatedNoiseRecordHasItsLength) {
  const Eigen::VectorXd x = repeated(uniform_noise(1234, 1.0, 7), 4);
  EXPECT_EQ(find_period(x), 1234);
}

TEST(FindPeriod, ARepeatedRecordWithMeasurementNoiseStillRepeats) {
  // 1 % noise on a unit-rms record: x(k+P) − x(k) has rms 1.4 % of it, below the 5 % tolerance.
  MultisineSpec spec;
  spec.period = 1000;
  spec.periods = 5;
  const Eigen::VectorXd clean = multisine(spec).signal;
  const Eigen::VectorXd x = clean + 0.01 * std::sqrt(clean.squaredNorm() / clean.size()) *
                                        std::sqrt(3.0) * uniform_noise(clean.size(), 1.0, 3);
  EXPECT_EQ(find_period(x), 1000);
}

TEST(FindPeriod, WhiteNoiseAndTooFewRepeatsHaveNone) {
  EXPECT_EQ(find_period(uniform_noise(8000, 1.0, 1)), 0);
  EXPECT_EQ(find_period(repeated(uniform_noise(1000, 1.0, 1), 2).head(1500)), 0) << "one and a half copies are not two";
  PeriodSearch three;
  three.min_repeats = 3;
  EXPECT_EQ(find_period(repeated(uniform_noise(1000, 1.0, 2), 2), three), 0);
  EXPECT_EQ(find_period(repeated(uniform_noise(1000, 1.0, 2), 3), three), 1000);
  EXPECT_EQ(find_period(Eigen::VectorXd::Constant(4000, 0.3)), 0);
}

TEST(FindPeriod, ASlowSineRepeatsAtItsCycleNotAtAShortLag) {
  // 3 Hz at 3 kHz: x(k+16) − x(k) is 2·sin(π·16·3/3000) ≈ 5 % of the amplitude·√2, small but not a repeat.
  Eigen::VectorXd x(6000);
  for (Eigen::Index k = 0; k < x.size(); ++k) x[k] = std::sin(2.0 * std::numbers::pi * 3.0 * k / 3000.0);
  EXPECT_EQ(find_period(x), 1000);
}

}  // namespace
}  // namespace panelbass::dsp

namespace panelbass::dsp {
namespace {

TEST(ClosestWholePeriods, PicksTheCountWhoseLengthIsNearestAWholeNumberOfSamples) {
  // A period of 37.5 samples: an even count of periods is a whole number of samples; the largest even one wins.
  EXPECT_EQ(closest_whole_periods(37.5, 80, 40), 80);
  EXPECT_EQ(closest_whole_periods(37.5, 79, 40), 78);
  // 3000/7 samples: 7 periods are exactly 3000 samples, the only whole count between 4 and 10.
  EXPECT_EQ(closest_whole_periods(3000.0 / 7.0, 10, 4), 7);
  // nothing to choose from: the lower bound
  EXPECT_EQ(closest_whole_periods(37.5, 2, 4), 4);
}

}  // namespace
}  // namespace panelbass::dsp

// power_db and magnitude_db against hand values: 10 dB a decade of power, 20 dB a decade of magnitude, NaN
// where there is no level.
#include "dsp/decibels.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>

namespace panelbass::dsp {
namespace {

TEST(Decibels, PowerIsTenDecibelsADecade) {
  Eigen::VectorXd p(4);
  p << 1.0, 10.0, 0.001, 0.0;
  const Eigen::VectorXd db = power_db(p);
  EXPECT_DOUBLE_EQ(db[0], 0.0);
  EXPECT_DOUBLE_EQ(db[1], 10.0);
  EXPECT_NEAR(db[2], -30.0, 1e-12);
  EXPECT_TRUE(std::isnan(db[3]));
  EXPECT_TRUE(std::isnan(power_db(Eigen::VectorXd::Constant(1, -1.0))[0]));
}

TEST(Decibels, MagnitudeIsTwentyDecibelsADecadeOfTheModulus) {
  Eigen::VectorXcd h(3);
  h << std::complex<double>(0.0, 10.0), std::complex<double>(3.0, -4.0), 0.0;  // |h| = 10, 5, 0
  const Eigen::VectorXd db = magnitude_db(h);
  EXPECT_NEAR(db[0], 20.0, 1e-12);
  EXPECT_NEAR(db[1], 20.0 * std::log10(5.0), 1e-12);
  EXPECT_TRUE(std::isnan(db[2]));
}

}  // namespace
}  // namespace panelbass::dsp

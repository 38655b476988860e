// Zero-phase decimation against sines: a tone in the band keeps its amplitude and phase sample for sample, a
// tone above the new Nyquist frequency is gone.
#include "dsp/decimate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "dsp/excitation.h"
#include "dsp/random.h"

namespace panelbass::dsp {
namespace {

constexpr double kPi = std::numbers::pi;


TEST(DecimateTest, SineInTheBandKeepsAmplitudeAndPhase) {
  const int factor = 3;
  const double f = 0.05;  // cycles per sample, below the cutoff 0.4/3 ≈ 0.133
  const Eigen::VectorXd x = sine(6000, 1.0, f, 1.0);
  const Eigen::VectorXd y = decimate(x, factor);
  ASSERT_EQ(y.size(), 2000);
  // Zero phase: the decimated samples are the original ones, x(3k) = sin(2π·f·3k), away from the edges.
  for (Eigen::Index k = 200; k < 1800; ++k) {
    EXPECT_NEAR(y[k], std::sin(2.0 * kPi * f * static_cast<double>(factor * k)), 1e-3) << "k = " << k;
  }
}

TEST(DecimateTest, SineAboveTheNewNyquistIsAttenuated) {
  const int factor = 3;
  const double f = 0.2;  // above 1/(2·3) ≈ 0.167: it would alias to 0.4 − 0.2·… after decimation
  const Eigen::VectorXd x = sine(6000, 1.0, f, 1.0);
  const Eigen::VectorXd y = decimate(x, factor);
  const double rms_in = std::sqrt(0.5);
  const double rms_out = std::sqrt(y.segment(200, 1600).squaredNorm() / 1600.0);
  EXPECT_LT(20.0 * std::log10(rms_out / rms_in), -40.0);
}

TEST(DecimateTest, FactorOneAndBadFactors) {
  const Eigen::VectorXd x = uniform_noise(101, 1.0, 5);
  EXPECT_EQ(decimate(x, 1), x);
  EXPECT_EQ(decimate(x, 4).size(), 26);  // samples 0, 4, …, 100
  EXPECT_THROW(decimate(x, 0), std::invalid_argument);
  EXPECT_THROW(decimate(x, -2), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::dsp

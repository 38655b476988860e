// fit_sine and sine_frequency against a sine built here: its coefficients a·cos + b·sin + c come back, the
// frequency is found far inside an FFT bin, and what is not one sine is refused.
#include "dsp/sine_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dsp/excitation.h"

namespace panelbass::dsp {
namespace {

Eigen::VectorXd sinusoid(Eigen::Index n, double fs, double f, double a, double b, double c) {
  Eigen::VectorXd x(n);
  const double w = 2.0 * std::numbers::pi * f / fs;
  for (Eigen::Index k = 0; k < n; ++k) x[k] = a * std::cos(w * k) + b * std::sin(w * k) + c;
  return x;
}

TEST(SineFit, RecoversTheCoefficientsAtTheRightFrequency) {
  const SineFit fit = fit_sine(sinusoid(3000, 3000.0, 80.0, 0.3, -0.4, 0.05), 3000.0, 80.0);
  EXPECT_NEAR(fit.coefficients[0], 0.3, 1e-12);
  EXPECT_NEAR(fit.coefficients[1], -0.4, 1e-12);
  EXPECT_NEAR(fit.coefficients[2], 0.05, 1e-12);
  EXPECT_LT(fit.residual, 1e-20);
}

TEST(SineFrequency, FindsAFrequencyBetweenBinsAndRefusesNoise) {
  // 80.37 Hz in 4000 samples at 3000 Hz: the FFT's bins (padded to 8192) are 0.37 Hz apart.
  const auto f = sine_frequency(sinusoid(4000, 3000.0, 80.37, 0.2, 0.5, 0.1), 3000.0);
  ASSERT_TRUE(f.has_value());
  EXPECT_NEAR(*f, 80.37, 1e-6);
  EXPECT_FALSE(sine_frequency(uniform_noise(4000, 1.0, 3), 3000.0).has_value());
  EXPECT_FALSE(sine_frequency(Eigen::VectorXd::Constant(4000, 0.3), 3000.0).has_value());
  EXPECT_FALSE(sine_frequency(Eigen::VectorXd::Ones(10), 3000.0).has_value());
}

// A distorted sine (30 % third harmonic, a little noise) is not one sine, but its fundamental is still the
// dominant frequency: within 1e-4 Hz (the third harmonic's leakage at the fundamental over 4000 samples).
TEST(DominantFrequency, FindsTheFundamentalOfADistortedSineThatSineFrequencyRefuses) {
  Eigen::VectorXd x = sinusoid(4000, 3000.0, 80.37, 0.2, 0.5, 0.1) + sinusoid(4000, 3000.0, 3 * 80.37, 0.1, 0.1, 0.0) +
                      uniform_noise(4000, 0.01, 5);
  EXPECT_FALSE(sine_frequency(x, 3000.0).has_value());
  const auto f = dominant_frequency(x, 3000.0);
  ASSERT_TRUE(f.has_value());
  EXPECT_NEAR(*f, 80.37, 1e-4);
  EXPECT_FALSE(dominant_frequency(Eigen::VectorXd::Constant(4000, 0.3), 3000.0).has_value());
}

}  // namespace
}  // namespace panelbass::dsp

// A discrete pole read as the continuous-time mode it samples: against poles built from a known mode.
#include "models/linear/transfer_function.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>

namespace panelbass::models {
namespace {

constexpr double kFs = 48000.0;

// The pole z = exp(s/fs) of the mode s = −ζω₀ + jω₀√(1−ζ²).
std::complex<double> sampled_pole(double natural_hz, double damping_ratio) {
  const double w0 = 2.0 * std::numbers::pi * natural_hz;
  const std::complex<double> s(-damping_ratio * w0, w0 * std::sqrt(1.0 - damping_ratio * damping_ratio));
  return std::exp(s / kFs);
}

TEST(PoleMode, ALightlyDampedPairGivesItsNaturalAndDampedFrequencyAndItsDamping) {
  for (const double zeta : {0.01, 0.3, 0.9}) {
    const PoleMode upper = pole_mode(sampled_pole(150.0, zeta), kFs);
    EXPECT_NEAR(upper.natural_hz, 150.0, 1e-9) << zeta;
    EXPECT_NEAR(upper.damped_hz, 150.0 * std::sqrt(1.0 - zeta * zeta), 1e-9) << zeta;
    EXPECT_NEAR(upper.damping_ratio, zeta, 1e-12) << zeta;
    // the conjugate is the same mode
    const PoleMode lower = pole_mode(std::conj(sampled_pole(150.0, zeta)), kFs);
    EXPECT_NEAR(lower.damped_hz, upper.damped_hz, 1e-9);
    EXPECT_NEAR(lower.damping_ratio, upper.damping_ratio, 1e-12);
  }
}

TEST(PoleMode, ARealPoleIsItsCornerFullyDampedAndAPoleAtOneIsAtRest) {
  // z = exp(−2π·740/fs): the first-order corner at 740 Hz
  const PoleMode corner = pole_mode(std::exp(-2.0 * std::numbers::pi * 740.0 / kFs), kFs);
  EXPECT_NEAR(corner.natural_hz, 740.0, 1e-9);
  EXPECT_EQ(corner.damped_hz, 0.0);
  EXPECT_NEAR(corner.damping_ratio, 1.0, 1e-12);
  const PoleMode integrator = pole_mode(1.0, kFs);
  EXPECT_EQ(integrator.natural_hz, 0.0);
  EXPECT_EQ(integrator.damping_ratio, 1.0);
}

}  // namespace
}  // namespace panelbass::models

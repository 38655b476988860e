// Closed-form checks of the analysis tools (the Analysis issue's list): the PSD of filtered white noise,
// and the harmonic levels a static polynomial makes of a sine.

#include <gtest/gtest.h>

#include <cmath>

#include "dsp/biquad.h"
#include "dsp/butterworth.h"
#include "dsp/excitation.h"
#include "dsp/harmonics.h"
#include "dsp/random.h"
#include "dsp/spectrum.h"

namespace panelbass::dsp {
namespace {

TEST(AnalysisClosedForm, PsdOfFilteredNoiseIsSigmaSquaredTimesGainSquaredOverHalfFs) {
  constexpr double fs = 3000.0, sigma = 0.5;
  Rng rng(4);
  Eigen::VectorXd white(1 << 18);
  for (Eigen::Index k = 0; k < white.size(); ++k) white[k] = sigma * rng.gaussian();
  SosFilter filter(butterworth_lowpass(4, 300.0, fs));
  const Eigen::VectorXd x = filter.process(white);
  const PowerSpectrum p = welch_psd(x, fs, {2048, 0.5, Window::hann});
  // S(f) = σ²·|H(f)|² / (fs/2) (one-sided density of white noise through H).
  for (double f : {50.0, 150.0, 250.0, 300.0, 400.0}) {
    const auto k = static_cast<Eigen::Index>(std::lround(f / (fs / 2048)));
    const double expected = sigma * sigma * std::norm(filter.response(p.frequency[k], fs)) / (fs / 2);
    // 255 averaged segments (50 % overlap, Hann): relative standard error ≈ 1/√(255·0.95) ≈ 6.5 %.
    EXPECT_NEAR(p.psd[k] / expected, 1.0, 0.25) << f << " Hz";
  }
}

TEST(AnalysisClosedForm, StaticPolynomialOfASineHasTheClosedFormHarmonics) {
  // y = x + a·x² + b·x³ with x = A·sin(ωt):  H2 amplitude a·A²/2, H3 amplitude b·A³/4,
  // fundamental A + 3b·A³/4.
  constexpr double fs = 3000.0, f = 75.0, A = 0.8, a = 0.2, b = 0.3;
  const Eigen::VectorXd x = sine(3000, fs, f, A);
  const Eigen::VectorXd y = x.array() + a * x.array().square() + b * x.array().cube();
  const HarmonicLevels h = harmonic_levels(y, fs, f, 5);
  EXPECT_NEAR(h.amplitude[0], A + 3 * b * A * A * A / 4, 1e-9);
  EXPECT_NEAR(h.amplitude[1], a * A * A / 2, 1e-9);
  EXPECT_NEAR(h.amplitude[2], b * A * A * A / 4, 1e-9);
  EXPECT_NEAR(h.amplitude[3], 0.0, 1e-9);
  EXPECT_NEAR(h.amplitude[4], 0.0, 1e-9);
}

}  // namespace
}  // namespace panelbass::dsp

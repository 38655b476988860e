// Welch PSD and H1 estimates against closed forms: white-noise level, sine power, Parseval, a known
// biquad's response, and the coherence of a noisy flat system.
#include "dsp/spectrum.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>

#include "dsp/biquad.h"
#include "dsp/random.h"
#include "tests/support/noise.h"

namespace panelbass::dsp {
namespace {

using testing_support::gaussian;
TEST(SpectrumWelchTest, FrequencyAxisIsBins) {
  const PowerSpectrum p = welch_psd(gaussian(1000, 1.0, 1), 3000.0, WelchSpec{256, 0.5, Window::hann});
  ASSERT_EQ(p.frequency.size(), 129);
  ASSERT_EQ(p.psd.size(), 129);
  for (Eigen::Index k = 0; k < 129; ++k) {
    EXPECT_DOUBLE_EQ(p.frequency[k], k * 3000.0 / 256.0);
  }
}

TEST(SpectrumWelchTest, WhiteNoiseIsFlatAtVarianceOverHalfFs) {
  // One-sided density of white noise: σ² / (fs/2). About 1000 half-overlapping Hann segments give
  // a per-bin relative standard error of sqrt(1.06/1000) ≈ 0.033 (Welch's overlap correction).
  const double sigma = 0.3;
  const double fs = 3000.0;
  const Eigen::VectorXd x = gaussian(1 << 17, sigma, 5);
  const PowerSpectrum p = welch_psd(x, fs, WelchSpec{256, 0.5, Window::hann});
  const double level = sigma * sigma / (fs / 2.0);
  double mean = 0.0;
  for (Eigen::Index k = 1; k < 128; ++k) {
    EXPECT_NEAR(p.psd[k] / level, 1.0, 5 * 0.033) << "bin " << k;
    mean += p.psd[k] / level / 127.0;
  }
  EXPECT_NEAR(mean, 1.0, 5 * 0.033 / std::sqrt(127.0));
  // DC and Nyquist are not doubled in a one-sided spectrum: half the level.
  EXPECT_NEAR(p.psd[0] / level, 0.5, 5 * 0.033);
  EXPECT_NEAR(p.psd[128] / level, 0.5, 5 * 0.033);
  // Integrated: the mean square, to the window-weighting's statistical error.
  const double df = fs / 256.0;
  EXPECT_NEAR(p.psd.sum() * df / (x.squaredNorm() / static_cast<double>(x.size())), 1.0, 0.01);
}

TEST(SpectrumWelchTest, RectangularWindowObeysParsevalExactly) {
  // Non-overlapping rectangular segments tiling x: Σ psd·df equals the mean square exactly, for
  // both an even and an odd segment length (the Nyquist bin exists only for even lengths).
  for (const std::size_t segment : {128u, 125u}) {
    const Eigen::VectorXd x = gaussian(static_cast<Eigen::Index>(segment) * 40, 1.7, 9).array() + 0.2;
    const PowerSpectrum p = welch_psd(x, 1000.0, WelchSpec{segment, 0.0, Window::rectangular});
    const double df = 1000.0 / static_cast<double>(segment);
    EXPECT_NEAR(p.psd.sum() * df, x.squaredNorm() / static_cast<double>(x.size()), 1e-12)
        << "segment " << segment;
  }
}

TEST(SpectrumWelchTest, SineTotalPowerIsHalfAmplitudeSquared) {
  // A sine of amplitude a has power a²/2; with a Hann window it spreads over a few bins around its
  // frequency (off-bin here, 1/3 of a bin from bin 44), and ±6 bins hold all but ~1e-4 of it.
  const double fs = 3000.0;
  const double a = 0.8;
  const std::size_t segment = 512;
  const double df = fs / segment;
  const double f = 44.333 * df;
  Eigen::VectorXd x(20000);
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    x[i] = a * std::sin(2.0 * std::numbers::pi * f * static_cast<double>(i) / fs + 0.3);
  }
  const PowerSpectrum p = welch_psd(x, fs, WelchSpec{segment, 0.5, Window::hann});
  Eigen::Index peak = 0;
  p.psd.maxCoeff(&peak);
  EXPECT_EQ(peak, 44);
  EXPECT_NEAR(p.psd.segment(44 - 6, 13).sum() * df / (a * a / 2.0), 1.0, 1e-3);
}

TEST(SpectrumFrfTest, H1OfBiquadMatchesItsResponse) {
  // y = a resonant biquad applied to white u: H1 is unbiased without output noise, so it matches
  // Biquad::response up to the leakage of a short impulse response within a 512-sample segment.
  const double fs = 3000.0;
  // Poles at radius 0.9, angle ±2π·400/3000; zeros at radius 0.5 on the real axis.
  const double r = 0.9;
  const double theta = 2.0 * std::numbers::pi * 400.0 / fs;
  Biquad b{1.0, -1.0, 0.25, -2.0 * r * std::cos(theta), r * r};
  SosFilter filter({b});
  const Eigen::VectorXd u = gaussian(1 << 16, 1.0, 3);
  const Eigen::VectorXd y = filter.process(u);
  const FrequencyResponse frf = h1_frf(u, y, fs, WelchSpec{512, 0.5, Window::hann});
  ASSERT_EQ(frf.h.size(), 257);
  for (Eigen::Index k = 1; k < 256; ++k) {
    const double f = frf.frequency[k];
    const std::complex<double> expected = b.response(f, fs);
    const double db_error = 20.0 * std::log10(std::abs(frf.h[k]) / std::abs(expected));
    EXPECT_LT(std::abs(db_error), 0.1) << "f " << f;
    EXPECT_LT(std::abs(std::arg(frf.h[k] / expected)), 0.02) << "f " << f;  // rad, about 1°
    EXPECT_GT(frf.coherence[k], 0.99) << "f " << f;
    EXPECT_LE(frf.coherence[k], 1.0);
  }
}

TEST(SpectrumFrfTest, CoherenceDropsWithOutputNoise) {
  // y = g·u + n, u and n white and independent: S = g²σu², N = σn², so H1 = g (noise on the output
  // does not bias H1) and γ² = 1/(1 + N/S) = 1/(1 + 1/2) = 2/3 here. With ~500 effective averages
  // the coherence estimate's standard error is about sqrt(2/K)·γ²(1 − γ²) ≈ 0.014.
  const double g = -1.5;
  const double sigma_u = 0.4;
  const double noise_to_signal = 0.5;
  const double sigma_n = std::sqrt(noise_to_signal) * std::abs(g) * sigma_u;
  const Eigen::VectorXd u = gaussian(1 << 17, sigma_u, 31);
  const Eigen::VectorXd y = g * u + gaussian(1 << 17, sigma_n, 32);
  const FrequencyResponse frf = h1_frf(u, y, 1000.0, WelchSpec{256, 0.5, Window::hann});
  const double expected = 1.0 / (1.0 + noise_to_signal);
  double mean_coherence = 0.0;
  std::complex<double> mean_h = 0.0;
  for (Eigen::Index k = 1; k < 128; ++k) {
    EXPECT_NEAR(frf.coherence[k], expected, 5 * 0.014) << "bin " << k;
    mean_coherence += frf.coherence[k] / 127.0;
    mean_h += frf.h[k] / 127.0;
  }
  EXPECT_NEAR(mean_coherence, expected, 0.01);
  EXPECT_NEAR(mean_h.real(), g, 0.01);
  EXPECT_NEAR(mean_h.imag(), 0.0, 0.01);
}

// The segment rule: the longest power of 2 from 64 to the cap that the record holds four times, counted by hand.
TEST(SpectrumWelchTest, TheSegmentIsTheLongestPowerOfTwoARecordHoldsFourTimes) {
  EXPECT_EQ(welch_segment(100), 64u);     // fewer than four of 64: still 64
  EXPECT_EQ(welch_segment(511), 64u);     // 511/4 = 127 < 128
  EXPECT_EQ(welch_segment(512), 128u);
  EXPECT_EQ(welch_segment(3000), 512u);   // 750 ≥ 512, < 1024
  EXPECT_EQ(welch_segment(4096), 1024u);
  EXPECT_EQ(welch_segment(1000000), 1024u);           // the default cap
  EXPECT_EQ(welch_segment(1000000, 4096), 4096u);     // the analysis's cap
  EXPECT_EQ(welch_segment(20000, 4096), 4096u);       // 5000 ≥ 4096
  EXPECT_EQ(welch_segment(16383, 4096), 2048u);       // 4095 < 4096
}

// The residual's rule: the longest power of 2 from 256 to 2048 that the record holds eight times, counted by hand.
TEST(SpectrumWelchTest, TheResidualSegmentIsTheLongestPowerOfTwoFrom256ARecordHoldsEightTimes) {
  EXPECT_EQ(residual_welch_segment(100), 64u);     // shorter than 256: the general rule's
  EXPECT_EQ(residual_welch_segment(1000), 256u);   // fewer than eight of 256: still 256
  EXPECT_EQ(residual_welch_segment(4095), 256u);   // 4095/8 = 511 < 512
  EXPECT_EQ(residual_welch_segment(4096), 512u);
  EXPECT_EQ(residual_welch_segment(20000), 2048u);   // 2500 ≥ 2048
  EXPECT_EQ(residual_welch_segment(16383), 1024u);   // 2047 < 2048
  EXPECT_EQ(residual_welch_segment(1000000), 2048u);  // the cap
}

TEST(SpectrumTest, InvalidInputsThrow) {
  const Eigen::VectorXd x = gaussian(100, 1.0, 1);
  EXPECT_THROW(welch_psd(x, 1000.0, WelchSpec{128, 0.5, Window::hann}), std::invalid_argument);
  EXPECT_THROW(welch_psd(x, 1000.0, WelchSpec{64, 1.0, Window::hann}), std::invalid_argument);
  EXPECT_THROW(welch_psd(x, 0.0, WelchSpec{64, 0.5, Window::hann}), std::invalid_argument);
  EXPECT_THROW(h1_frf(x, gaussian(99, 1.0, 2), 1000.0, WelchSpec{64, 0.5, Window::hann}),
               std::invalid_argument);
  EXPECT_THROW(h1_frf(x, x, 1000.0, WelchSpec{128, 0.5, Window::hann}), std::invalid_argument);
  EXPECT_NO_THROW(welch_psd(x, 1000.0, WelchSpec{100, 0.5, Window::hann}));
}

}  // namespace
}  // namespace panelbass::dsp

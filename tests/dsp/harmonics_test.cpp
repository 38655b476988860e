// harmonic_levels on synthetic sums of sines with known amplitudes over whole periods (where the
// single-bin DFT has no leakage, so the amplitudes come back to rounding), THD and relative levels
// against their closed forms, the Nyquist cut-off, and the argument checks.
#include "dsp/harmonics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <vector>

#include "tests/support/noise.h"

namespace panelbass::dsp {
namespace {

/// Σ_h a_h·sin(2π·h·f·k/fs + φ_h) + dc for k = 0..samples−1.
Eigen::VectorXd sum_of_sines(Eigen::Index samples, double fs, double f, const std::vector<double>& a,
                             const std::vector<double>& phase, double dc = 0.0) {
  Eigen::VectorXd x = Eigen::VectorXd::Constant(samples, dc);
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double w = 2.0 * std::numbers::pi * static_cast<double>(i + 1) * f / fs;
    for (Eigen::Index k = 0; k < samples; ++k) x[k] += a[i] * std::sin(w * static_cast<double>(k) + phase[i]);
  }
  return x;
}

TEST(HarmonicLevelsTest, RecoversKnownAmplitudesOverWholePeriods) {
  const double fs = 48000.0, f = 1000.0;  // 48 samples a period; 4800 samples = 100 periods
  const std::vector<double> a = {0.8, 0.1, 0.05, 0.0, 0.01};
  const std::vector<double> phase = {0.3, -1.1, 2.0, 0.7, -0.4};
  const Eigen::VectorXd x = sum_of_sines(4800, fs, f, a, phase, 0.25);  // a DC offset must not leak
  const HarmonicLevels lv = harmonic_levels(x, fs, f, 5);
  EXPECT_EQ(lv.frequency, f);
  ASSERT_EQ(lv.amplitude.size(), 5u);
  for (std::size_t h = 0; h < a.size(); ++h) EXPECT_NEAR(lv.amplitude[h], a[h], 1e-10) << "harmonic " << h + 1;
}

TEST(HarmonicLevelsTest, NonIntegerFrequencyRatioOverWholePeriods) {
  // f = 440 Hz at fs = 44100: a period is 2205/22 samples, so 2205 samples hold exactly 22 periods.
  const double fs = 44100.0, f = 440.0;
  const std::vector<double> a = {0.5, 0.02, 0.03};
  const std::vector<double> phase = {0.0, 1.0, -2.5};
  const HarmonicLevels lv = harmonic_levels(sum_of_sines(2205, fs, f, a, phase), fs, f, 3);
  ASSERT_EQ(lv.amplitude.size(), 3u);
  for (std::size_t h = 0; h < a.size(); ++h) EXPECT_NEAR(lv.amplitude[h], a[h], 1e-10) << "harmonic " << h + 1;
}

TEST(HarmonicLevelsTest, ThdIsRootSumOfHarmonicPowersOverFundamental) {
  const double fs = 48000.0, f = 1000.0;
  const std::vector<double> a = {0.8, 0.1, 0.05, 0.0, 0.01};
  const std::vector<double> phase = {0.3, -1.1, 2.0, 0.7, -0.4};
  const HarmonicLevels lv = harmonic_levels(sum_of_sines(4800, fs, f, a, phase), fs, f, 5);
  const double expected = std::sqrt(0.1 * 0.1 + 0.05 * 0.05 + 0.0 + 0.01 * 0.01) / 0.8 * 100.0;
  EXPECT_NEAR(lv.thd_percent(), expected, 1e-8);
}

TEST(HarmonicLevelsTest, ThdOfHandBuiltLevels) {
  HarmonicLevels lv;
  lv.amplitude = {2.0, 0.3, 0.4};  // sqrt(0.09 + 0.16) = 0.5 → 25 %
  EXPECT_NEAR(lv.thd_percent(), 25.0, 1e-12);
  lv.amplitude = {2.0};  // a fundamental alone has no distortion
  EXPECT_EQ(lv.thd_percent(), 0.0);
  lv.amplitude = {0.0, 0.1};  // no fundamental: undefined
  EXPECT_TRUE(std::isnan(lv.thd_percent()));
  lv.amplitude.clear();
  EXPECT_TRUE(std::isnan(lv.thd_percent()));
}

TEST(HarmonicLevelsTest, RelativeDbIs20Log10OfAmplitudeRatio) {
  const double fs = 48000.0, f = 1000.0;
  const std::vector<double> a = {0.8, 0.1, 0.05};
  const std::vector<double> phase = {0.0, 0.0, 0.0};
  const HarmonicLevels lv = harmonic_levels(sum_of_sines(4800, fs, f, a, phase), fs, f, 3);
  EXPECT_NEAR(lv.relative_db(1), 0.0, 1e-12);
  EXPECT_NEAR(lv.relative_db(2), 20.0 * std::log10(0.1 / 0.8), 1e-8);  // ≈ −18.06 dB
  EXPECT_NEAR(lv.relative_db(3), 20.0 * std::log10(0.05 / 0.8), 1e-8);  // ≈ −24.08 dB

  HarmonicLevels hand;
  hand.amplitude = {1.0, 0.01, 0.0};
  EXPECT_NEAR(hand.relative_db(2), -40.0, 1e-12);
  EXPECT_EQ(hand.relative_db(3), -std::numeric_limits<double>::infinity());
  EXPECT_THROW(hand.relative_db(0), std::out_of_range);
  EXPECT_THROW(hand.relative_db(4), std::out_of_range);
}

// A sine is a cosine delayed by a quarter period: sin(θ + φ) = cos(θ + φ − π/2).
TEST(HarmonicLevelsTest, PhasesAreThoseOfTheCosinesOverWholePeriods) {
  const double fs = 48000.0, f = 1000.0;
  const std::vector<double> a = {0.8, 0.1, 0.05};
  const std::vector<double> phase = {0.3, -1.1, 2.0};
  const HarmonicLevels lv = harmonic_levels(sum_of_sines(4800, fs, f, a, phase), fs, f, 3);
  ASSERT_EQ(lv.phase.size(), 3u);
  for (std::size_t h = 0; h < a.size(); ++h) {
    EXPECT_NEAR(std::remainder(lv.phase[h] - (phase[h] - std::numbers::pi / 2), 2 * std::numbers::pi), 0.0, 1e-10)
        << "harmonic " << h + 1;
  }
}

// relative(h) = (a_h/a_1)·e^{j(φ_h − h·φ_1)} with cosine phases, and a delay of d samples (φ_h → φ_h − h·ω·d)
// leaves it as it is.
TEST(HarmonicLevelsTest, RelativeHarmonicIsLevelAndPhaseAgainstTheFundamentalWhateverTheDelay) {
  const double fs = 48000.0, f = 1000.0;
  const std::vector<double> a = {0.8, 0.1, 0.05};
  const std::vector<double> phase = {0.3, -1.1, 2.0};
  for (const int delay : {0, 7, 30}) {
    std::vector<double> delayed = phase;
    for (std::size_t h = 0; h < a.size(); ++h) {
      delayed[h] -= static_cast<double>(h + 1) * 2.0 * std::numbers::pi * f / fs * delay;
    }
    const HarmonicLevels lv = harmonic_levels(sum_of_sines(4800, fs, f, a, delayed), fs, f, 3);
    EXPECT_NEAR(std::abs(lv.relative(1) - 1.0), 0.0, 1e-10);
    for (std::size_t h = 2; h <= 3; ++h) {
      // sine phases: φ_h − π/2 − h·(φ_1 − π/2) = φ_h − h·φ_1 + (h − 1)·π/2
      const std::complex<double> expected =
          std::polar(a[h - 1] / a[0], phase[h - 1] - h * phase[0] + (h - 1.0) * std::numbers::pi / 2);
      EXPECT_NEAR(std::abs(lv.relative(h) - expected), 0.0, 1e-10) << "harmonic " << h << ", delay " << delay;
    }
  }
  HarmonicLevels hand;
  hand.amplitude = {1.0, 0.1};
  hand.phase = {0.0, 0.0};
  EXPECT_THROW(hand.relative(3), std::out_of_range);
  EXPECT_THROW(hand.relative(0), std::out_of_range);
}

// y = x + c·x³ on x = A·cos θ: cos³θ = (3·cos θ + cos 3θ)/4, so H3 is (c·A³/4)/(A + 3·c·A³/4), in phase with
// the cosine fundamental for c > 0 and opposite to it for c < 0 — and the same on x = A·sin θ.
TEST(HarmonicLevelsTest, CubicNonlinearityHasItsClosedFormRelativeThirdHarmonic) {
  const double fs = 48000.0, f = 1000.0, amplitude = 0.7;
  for (const double c : {0.2, -0.2}) {
    for (const double start : {0.0, -std::numbers::pi / 2}) {  // cosine, then sine
      Eigen::VectorXd y(4800);
      for (Eigen::Index k = 0; k < y.size(); ++k) {
        const double x = amplitude * std::cos(2.0 * std::numbers::pi * f / fs * k + start);
        y[k] = x + c * x * x * x;
      }
      const HarmonicLevels lv = harmonic_levels(y, fs, f, 3);
      const double a3 = c * std::pow(amplitude, 3) / 4, a1 = amplitude + 3 * c * std::pow(amplitude, 3) / 4;
      EXPECT_NEAR(std::abs(lv.relative(3) - a3 / a1), 0.0, 1e-10) << "c " << c << ", start " << start;
      EXPECT_NEAR(std::abs(lv.relative(2)), 0.0, 1e-10);
    }
  }
}

TEST(HarmonicLevelsTest, HarmonicsAtOrAboveNyquistAreNotReported) {
  const double fs = 48000.0;
  const Eigen::VectorXd x = sum_of_sines(4800, fs, 1000.0, {1.0}, {0.0});
  // f = 10 kHz: 2f = 20 kHz < 24 kHz reported, 3f = 30 kHz not.
  EXPECT_EQ(harmonic_levels(x, fs, 10000.0, 5).amplitude.size(), 2u);
  // f = 8 kHz: 3f = 24 kHz is exactly Nyquist, not reported.
  EXPECT_EQ(harmonic_levels(x, fs, 8000.0, 5).amplitude.size(), 2u);
  // f = 12 kHz: 2f is Nyquist; only the fundamental.
  EXPECT_EQ(harmonic_levels(x, fs, 12000.0, 5).amplitude.size(), 1u);
  // Below Nyquist, max_order bounds the count.
  EXPECT_EQ(harmonic_levels(x, fs, 1000.0, 5).amplitude.size(), 5u);
  EXPECT_EQ(harmonic_levels(x, fs, 1000.0, 2).amplitude.size(), 2u);
}

TEST(HarmonicLevelsTest, InvalidFrequencyThrows) {
  const double fs = 48000.0;
  const Eigen::VectorXd x = sum_of_sines(480, fs, 1000.0, {1.0}, {0.0});
  EXPECT_THROW(harmonic_levels(x, fs, 0.0), std::invalid_argument);
  EXPECT_THROW(harmonic_levels(x, fs, -1000.0), std::invalid_argument);
  EXPECT_THROW(harmonic_levels(x, fs, fs / 2.0), std::invalid_argument);
  EXPECT_THROW(harmonic_levels(x, fs, 30000.0), std::invalid_argument);
  EXPECT_THROW(harmonic_levels(x, fs, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  EXPECT_THROW(harmonic_levels(Eigen::VectorXd::Zero(1), fs, 1000.0), std::invalid_argument);
}

// steady_thd on a sum of sines with white Gaussian noise of known σ: the floor is its closed form
// 100·sqrt(count·4σ²/N)/a₁ (σ read back from the residual), the THD with the noise taken out comes back to the
// clean THD, and the stated uncertainty is the spread over seeds.
TEST(SteadyThdTest, ReadsTheNoiseFloorAndTakesTheNoiseOut) {
  const double fs = 3000.0, f = 80.0, sigma = 0.01;
  const std::vector<double> a = {0.5, 0.004, 0.003, 0.0, 0.0}, phase = {0.1, 0.7, -1.2, 0.0, 0.0};
  const double clean = 100.0 * std::hypot(0.004, 0.003) / 0.5;  // 1 %
  const Eigen::Index samples = 12000;
  std::vector<double> db;
  double mean_measured = 0.0;
  constexpr int kSeeds = 60;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const Eigen::VectorXd y = sum_of_sines(samples, fs, f, a, phase, 0.2) + testing_support::gaussian(samples, sigma, seed);
    const std::optional<SteadyThd> t = steady_thd(y, fs, f);
    ASSERT_TRUE(t.has_value());
    const double floor = 100.0 * std::sqrt(4.0 * 4.0 * sigma * sigma / static_cast<double>(t->samples)) / 0.5;
    EXPECT_NEAR(t->floor_pct, floor, 0.1 * floor);
    EXPECT_FALSE(t->at_floor);
    EXPECT_NEAR(t->measured_thd_pct, *steady_thd_percent(y, fs, f), 1e-12);
    db.push_back(20.0 * std::log10(t->thd_pct / clean));
    mean_measured += 20.0 * std::log10(t->measured_thd_pct / clean) / kSeeds;
    if (seed == 1) {
      // (10/ln 10)·sqrt(2P·F + 4F²)/P with F = 4σ²/N, P = clean power
      const double f_bin = 4.0 * sigma * sigma / static_cast<double>(t->samples), p = 0.004 * 0.004 + 0.003 * 0.003;
      EXPECT_NEAR(t->uncertainty_db, 10.0 / std::numbers::ln10 * std::sqrt(2.0 * p * f_bin + 4.0 * f_bin * f_bin) / p, 0.1);
    }
  }
  double mean = 0.0, spread = 0.0;
  for (double d : db) mean += d / kSeeds;
  for (double d : db) spread += (d - mean) * (d - mean) / (kSeeds - 1);
  spread = std::sqrt(spread);
  EXPECT_NEAR(mean, 0.0, 0.1) << "the noise's share taken out: unbiased";
  EXPECT_GT(mean_measured, mean) << "the raw reading carries the noise's share";
  const Eigen::VectorXd y1 = sum_of_sines(samples, fs, f, a, phase, 0.2) + testing_support::gaussian(samples, sigma, 1);
  EXPECT_NEAR(spread, steady_thd(y1, fs, f)->uncertainty_db, 0.5 * spread) << "the stated uncertainty is the spread";

  // A pure sine in the same noise: at the floor.
  const Eigen::VectorXd pure = sum_of_sines(samples, fs, f, {0.5}, {0.3}) + testing_support::gaussian(samples, sigma, 7);
  const std::optional<SteadyThd> t = steady_thd(pure, fs, f);
  ASSERT_TRUE(t.has_value());
  EXPECT_TRUE(t->at_floor);
  EXPECT_LT(t->measured_thd_pct, std::sqrt(2.0) * t->floor_pct);
  EXPECT_FALSE(steady_thd(pure.head(100), fs, f).has_value()) << "fewer than 4 periods";
}

}  // namespace
}  // namespace panelbass::dsp

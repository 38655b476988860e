// Offline resampling through libsamplerate, against signals written down in closed form: a sine
// resampled is the same sine sampled at the new rate, content above the new Nyquist frequency is
// removed, a round trip returns the signal, and the lengths are round(n · to/from).
#include "dsp/resample.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>

#include "tests/support/expect_error.h"

namespace panelbass::dsp {
namespace {

// Σ a_i·sin(2π f_i k / fs + φ_i), k = 0..n−1.
Eigen::VectorXd tones(Eigen::Index n, double fs, std::initializer_list<std::array<double, 3>> components) {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    for (const auto& [a, f, phi] : components) x[k] += a * std::sin(2.0 * std::numbers::pi * f * k / fs + phi);
  }
  return x;
}

// Largest |a − b| away from the edges (the first and last `margin` samples), where a finite signal's
// abrupt start and end ring through any band-limited converter.
double interior_error(const Eigen::VectorXd& a, const Eigen::VectorXd& b, Eigen::Index margin) {
  return (a - b).segment(margin, a.size() - 2 * margin).cwiseAbs().maxCoeff();
}

TEST(Resample, UpsamplingASineGivesTheSameSineAtTheNewRate) {
  const auto x = tones(3000, 3000.0, {{0.8, 100.0, 0.3}, {0.1, 1100.0, 1.0}});
  const Eigen::VectorXd y = resample(x, 3000.0, 48000.0);
  ASSERT_EQ(y.size(), 48000);
  const auto expected = tones(48000, 48000.0, {{0.8, 100.0, 0.3}, {0.1, 1100.0, 1.0}});
  EXPECT_LE(interior_error(y, expected, 4800), 1e-6);  // single precision inside libsamplerate
}

TEST(Resample, DownsamplingRemovesWhatLiesAboveTheNewNyquistFrequency) {
  // 5 kHz cannot exist at 3000 Hz: only the 100 Hz tone survives.
  const auto x = tones(48000, 48000.0, {{0.5, 100.0, 0.0}, {0.4, 5000.0, 0.7}});
  const Eigen::VectorXd y = resample(x, 48000.0, 3000.0);
  ASSERT_EQ(y.size(), 3000);
  EXPECT_LE(interior_error(y, tones(3000, 3000.0, {{0.5, 100.0, 0.0}}), 300), 1e-5);
}

TEST(Resample, ARoundTripThroughAnotherRateReturnsTheSignal) {
  const auto x = tones(6000, 3000.0, {{0.3, 55.0, 0.1}, {0.3, 440.0, 2.0}, {0.2, 1000.0, -1.0}});
  const Eigen::VectorXd back = resample(resample(x, 3000.0, 44100.0), 44100.0, 3000.0);
  ASSERT_EQ(back.size(), x.size());
  EXPECT_LE(interior_error(back, x, 300), 1e-5);
}

TEST(Resample, LengthIsTheRoundedRatioAndEqualRatesChangeNothing) {
  const Eigen::VectorXd x = tones(7, 3000.0, {{0.5, 100.0, 0.0}});
  EXPECT_EQ(resample(x, 3000.0, 44100.0).size(), 103);  // 7 · 14.7 = 102.9
  EXPECT_EQ(resample(x, 3000.0, 48000.0).size(), 112);
  EXPECT_EQ(resample(tones(1001, 48000.0, {{0.5, 100.0, 0.0}}), 48000.0, 3000.0).size(), 63);  // 62.56
  EXPECT_EQ(resample(Eigen::VectorXd(), 3000.0, 48000.0).size(), 0);
  EXPECT_EQ(resample(x, 3000.0, 3000.0), x);
}

TEST(Resample, RefusesBadRatesAndSamplesNamingThem) {
  const Eigen::VectorXd x = Eigen::VectorXd::Ones(10);
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  for (const auto& rates : {std::pair{0.0, 3000.0}, {3000.0, -1.0}, {nan, 3000.0}}) {
    const std::string message =
        testing_support::one_line_error<std::invalid_argument>([&] { resample(x, rates.first, rates.second); });
    EXPECT_NE(message.find("rates must be finite and > 0"), std::string::npos) << message;
  }
  EXPECT_NE(testing_support::one_line_error<std::invalid_argument>([&] { resample(x, 100.0, 48000.0); })
                .find("ratio outside [1/256, 256]"),
            std::string::npos);
  Eigen::VectorXd bad = x;
  bad[3] = nan;
  EXPECT_NE(testing_support::one_line_error<std::invalid_argument>([&] { resample(bad, 3000.0, 48000.0); })
                .find("non-finite sample"),
            std::string::npos);
}

}  // namespace
}  // namespace panelbass::dsp

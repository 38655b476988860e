// One window of a JACK transducer's record judged as a sine response, against signals built here with known
// content: a drive at 80 Hz (its frequency between FFT bins of the window), an acceleration with a 3rd harmonic
// at 10 % and a 2nd at 5 % (THD √(0.1² + 0.05²) = 11.18 %), the same with white noise for the sensor. The
// noise-free figures are exact to 1e-7 of their value: 80 Hz is a whole 600 samples a period at 48 kHz, and the
// frequency found from the drive is off by no more than the search's stop (1e-10·fs, 4.8 µHz: a phase drift of
// 2e-5 rad over the 0.75 s read, 1e-8 of an amplitude); the sensor's, with the noise's share taken out, within
// three of its own standard deviations; a silent drive gives no frequency.
#include "evaluation/window_distortion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dsp/excitation.h"
#include "dsp/random.h"

namespace panelbass::evaluation {
namespace {

constexpr double kFs = 48000.0;

Eigen::VectorXd tone(Eigen::Index n, double f, double a, double phase = 0.0) {
  Eigen::VectorXd x(n);
  for (Eigen::Index k = 0; k < n; ++k) x[k] = a * std::sin(2.0 * std::numbers::pi * f * static_cast<double>(k) / kFs + phase);
  return x;
}

TEST(WindowDistortion, ReadsTheDrivesFrequencyAndEachSignalsFundamentalAndThd) {
  const Eigen::Index n = 48000;
  const Eigen::VectorXd drive = tone(n, 80.0, 0.3);
  const Eigen::VectorXd clean = tone(n, 80.0, 0.5, 0.3) + tone(n, 240.0, 0.05, 1.0) + tone(n, 160.0, 0.025, -0.4);
  dsp::Rng rng(4);
  Eigen::VectorXd sensor = clean;
  for (Eigen::Index k = 0; k < n; ++k) sensor[k] += 0.01 * rng.gaussian();
  const WindowDistortion w = window_distortion(drive, sensor, clean, kFs);
  ASSERT_TRUE(w.frequency_hz);
  EXPECT_NEAR(*w.frequency_hz, 80.0, 1e-6);
  EXPECT_NEAR(w.drive_rms, 0.3 / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(w.drive_peak, 0.3, 1e-6);
  EXPECT_NEAR(w.drive_fundamental, 0.3, 1e-7 * 0.3);
  EXPECT_NEAR(w.clean_fundamental, 0.5, 1e-7 * 0.5);
  ASSERT_TRUE(w.drive_thd_pct && w.clean_thd_pct && w.sensor_thd_pct && w.sensor_floor_pct);
  EXPECT_LT(*w.drive_thd_pct, 1e-5);
  const double thd = 100.0 * std::hypot(0.05, 0.025) / 0.5;
  EXPECT_NEAR(*w.clean_thd_pct, thd, 1e-7 * thd);
  // The noise (σ 0.01) in each single-bin amplitude over N = 36000 samples: √(4σ²/N) = 1.05e-4, 0.02 % of a₁.
  EXPECT_NEAR(w.sensor_fundamental, 0.5, 3.0 * 1.05e-4);
  EXPECT_NEAR(*w.sensor_thd_pct, thd, 3.0 * 100.0 * 1.05e-4 / 0.5);
  EXPECT_GT(*w.sensor_floor_pct, 0.0);
  EXPECT_FALSE(w.sensor_at_floor);
}

TEST(WindowDistortion, ASilentDriveHasNoFrequencyAndUnequalColumnsAreRefused) {
  const Eigen::VectorXd zeros = Eigen::VectorXd::Zero(4800), noise = dsp::uniform_noise(4800, 0.1, 2);
  const WindowDistortion w = window_distortion(zeros, noise, noise, kFs);
  EXPECT_FALSE(w.frequency_hz);
  EXPECT_FALSE(w.clean_thd_pct);
  EXPECT_EQ(w.drive_peak, 0.0);
  EXPECT_THROW(window_distortion(zeros, noise.head(100), noise, kFs), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::evaluation

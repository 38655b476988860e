// The measurement's parts that need no device: the round trip found by cross-correlation, the device
// thread's side of a play-and-capture, and the plant simulated at a card's rate.
//
// Independent expectations: a signal delayed by a known whole number of samples is found at that delay;
// one delayed by half a sample (the mean of two neighbours) is refined to it; the device side returns the
// drive sample by sample and keeps what it was given; the plant rescaled to 48 kHz answers a drive held
// over each 3000 Hz sample exactly as the plant at 3000 Hz does (noise off), sampled every 16th frame; a
// loop built as a known filter and delay is explained by its drive, and the same loop with a period
// repeated (or repeated, then dropped again) at a known sample is not, from that window on.
#include "engine/measurement.h"

#include <gtest/gtest.h>

#include "engine/jack_transducer.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "tests/engine/engine_test_models.h"

namespace panelbass::engine {
namespace {

TEST(Measurement, TheRoundTripOfADelayedSignalIsItsDelay) {
  const Eigen::VectorXd u = testing::uniform(4000, 0.5, 1);
  Eigen::VectorXd heard = Eigen::VectorXd::Zero(4000);
  heard.tail(4000 - 37) = 0.8 * u.head(4000 - 37);
  const RoundTrip trip = find_round_trip(u, heard, 200);
  EXPECT_EQ(trip.samples, 37);
  EXPECT_NEAR(trip.fractional, 37.0, 0.05);
  EXPECT_GT(trip.peak, 0.99);
  // Half a sample more: the mean of two neighbours (a low-pass whose delay is 37.5 samples).
  Eigen::VectorXd half = Eigen::VectorXd::Zero(4000);
  for (Eigen::Index k = 38; k < 4000; ++k) half[k] = 0.5 * (u[k - 37] + u[k - 38]);
  EXPECT_NEAR(find_round_trip(u, half, 200).fractional, 37.5, 0.05);
  EXPECT_THROW(find_round_trip(u, heard.head(100), 20), std::invalid_argument);
}

TEST(Measurement, TheDeviceSideReturnsTheDriveAndKeepsTheCaptures) {
  Measurement m({0.1, -0.2, 0.3}, 4);
  EXPECT_EQ(m.state(), Measurement::State::pending);
  ASSERT_TRUE(m.begin());
  EXPECT_EQ(m.state(), Measurement::State::running);
  bool done = false;
  EXPECT_EQ(m.step(1.0, 2.0, 3.0, done), 0.1);
  EXPECT_FALSE(done);
  EXPECT_EQ(m.step(4.0, 5.0, 6.0, done), -0.2);
  EXPECT_EQ(m.step(7.0, 8.0, 9.0, done), 0.3);
  EXPECT_TRUE(done);
  EXPECT_EQ(m.state(), Measurement::State::finished);
  EXPECT_EQ(m.captured(MeasuredChannel::sensor), (std::vector<double>{1.0, 4.0, 7.0}));
  EXPECT_EQ(m.captured(MeasuredChannel::current), (std::vector<double>{2.0, 5.0, 8.0}));
  EXPECT_EQ(m.captured(MeasuredChannel::loopback), (std::vector<double>{3.0, 6.0, 9.0}));

  Measurement cancelled({0.0}, 1);
  cancelled.cancel();
  EXPECT_FALSE(cancelled.begin());
  EXPECT_EQ(cancelled.state(), Measurement::State::aborted);
  EXPECT_THROW(Measurement({}, 1), std::invalid_argument);
  EXPECT_THROW(Measurement({0.5, 1.01}, 1), std::invalid_argument);
  EXPECT_THROW(Measurement({0.5}, 0), std::invalid_argument);
}

TEST(Measurement, ThePlantAtACardsRateIsThePlantAtItsOwn) {
  models::PlantConfig plant = models::plant_preset("panel-exciter");
  plant.sensor.noise_rms_V = 0.0;
  const models::PlantConfig fast = plant_at_rate(plant, 16.0 * plant.fs);
  EXPECT_EQ(fast.fs, 16.0 * plant.fs);
  EXPECT_EQ(fast.converters.delay_samples, 16 * plant.converters.delay_samples);
  EXPECT_EQ(fast.oversample, std::max(1, plant.oversample / 16));
  models::VirtualTransducer slow_t(plant, 1), fast_t(fast, 1);
  const Eigen::VectorXd u = testing::uniform(600, 0.5, 2);
  double worst = 0.0, scale = 0.0;
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    const double y = slow_t.step(u[k]).y;
    double y_fast = 0.0;
    for (int j = 0; j < 16; ++j) y_fast = fast_t.step(u[k]).y;  // the drive held, as the plant's DA holds it
    worst = std::max(worst, std::abs(y - y_fast));
    scale = std::max(scale, std::abs(y));
  }
  EXPECT_LT(worst, 1e-9 * scale + 1e-12) << "scale " << scale;
  models::PlantConfig noisy = plant;
  noisy.sensor.noise_rms_V = 0.001;
  EXPECT_DOUBLE_EQ(plant_at_rate(noisy, 4.0 * plant.fs).sensor.noise_rms_V, 0.002);
  EXPECT_THROW(plant_at_rate(plant, 0.0), std::invalid_argument);
}

// A microphone's delay (2.5 samples: 40 integrator steps at either rate) is kept in time: the plant at 16 times its
// rate reads what the plant at its own rate reads.
TEST(Measurement, AMicrophonesDelayIsKeptInTimeAtACardsRate) {
  models::PlantConfig plant = models::plant_preset("linear");
  plant.sensor.noise_rms_V = 0.0;
  plant.sensor.kind = models::SensorKind::microphone;
  plant.sensor.delay_samples = 2.5;
  const models::PlantConfig fast = plant_at_rate(plant, 16.0 * plant.fs);
  EXPECT_EQ(fast.sensor.delay_samples, 40.0);
  models::VirtualTransducer slow_t(plant, 1), fast_t(fast, 1);
  const Eigen::VectorXd u = testing::uniform(600, 0.5, 2);
  double worst = 0.0, scale = 0.0;
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    const double y = slow_t.step(u[k]).y;
    double y_fast = 0.0;
    for (int j = 0; j < 16; ++j) y_fast = fast_t.step(u[k]).y;
    worst = std::max(worst, std::abs(y - y_fast));
    scale = std::max(scale, std::abs(y));
  }
  EXPECT_GT(scale, 0.0);
  EXPECT_LT(worst, 1e-9 * scale + 1e-12) << "scale " << scale;
}

// A loop: the drive (noise, with silent gaps as a measurement has) through a three-tap low-pass, 37 samples
// later; from `slip_from` to `slip_to` the capture runs `slip` samples late (a repeated period).
struct SlippedLoop {
  Eigen::VectorXd played, heard;
};
SlippedLoop measurement_loop(Eigen::Index slip_from, Eigen::Index slip_to, Eigen::Index slip) {
  const Eigen::Index n = 9000;
  SlippedLoop loop{testing::uniform(n, 0.5, 3), Eigen::VectorXd::Zero(n)};
  loop.played.segment(2000, 300).setZero();
  loop.played.tail(400).setZero();
  Eigen::VectorXd clean = Eigen::VectorXd::Zero(n);
  for (Eigen::Index k = 39; k < n; ++k) {
    clean[k] = 0.25 * loop.played[k - 37] + 0.5 * loop.played[k - 38] + 0.25 * loop.played[k - 39];
  }
  for (Eigen::Index k = 0; k < n; ++k) {
    loop.heard[k] = k >= slip_from && k < slip_to && k >= slip ? clean[k - slip] : clean[k];
  }
  return loop;
}

TEST(Measurement, ACleanLoopbackIsExplainedByItsDriveSampleBySample) {
  const SlippedLoop loop = measurement_loop(0, 0, 0);
  const LoopConsistency c = check_loop(loop.played, loop.heard, 38, kLoopTolerance);
  EXPECT_FALSE(c.slipped);
  EXPECT_LT(c.worst_residual, 1e-12);
  EXPECT_THROW(check_loop(loop.played, loop.heard.head(100), 38, kLoopTolerance), std::invalid_argument);
  EXPECT_THROW(check_loop(loop.played, loop.heard, 9000, kLoopTolerance), std::invalid_argument);
}

TEST(Measurement, APeriodRepeatedOrDroppedInsideTheLoopIsFound) {
  // A period of 64 frames at 48 kHz is 4 samples at 3000 Hz: repeated from sample 5000 to the end.
  const SlippedLoop late = measurement_loop(5000, 9000, 4);
  const LoopConsistency c = check_loop(late.played, late.heard, 38, kLoopTolerance);
  EXPECT_TRUE(c.slipped);
  EXPECT_GT(c.worst_residual, 0.1);
  // Repeated at 3000, dropped again at 4000: the sweeps before and after would agree; the loopback does not.
  const SlippedLoop back = measurement_loop(3000, 4000, 4);
  const LoopConsistency b = check_loop(back.played, back.heard, 38, kLoopTolerance);
  EXPECT_TRUE(b.slipped);
  EXPECT_GE(b.worst_at, 3000 - kLoopWindow);
  EXPECT_LT(b.worst_at, 4000 + kLoopWindow);
  // One sample is enough.
  EXPECT_TRUE(check_loop(back.played, measurement_loop(3000, 4000, 1).heard, 38, kLoopTolerance).slipped);
}

}  // namespace
}  // namespace panelbass::engine

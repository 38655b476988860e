// The ALSA backend through real libasound calls with real-time pacing: the test starts a JACK server
// with the dummy driver (Debian jackd2) and opens two ALSA PCMs of type "jack" (Debian
// libasound2-plugins) from an in-memory configuration, wired as a loopback: the capture PCM's sensor
// channel is connected to the playback PCM's drive port, so what the backend plays really comes back on
// its capture. The chain runs at 3000 Hz between the rate bridge's decimator and interpolator, the
// device at 48 kHz with 64-frame periods.
//
// Independent expectations: a digital loop returns every drive sample exactly (as the float it was
// written as) some whole number of frames later, so once the delay is found by cross-correlation the
// captured sensor must equal the delayed drive sample for sample; zero xruns while the server runs; the
// drive within [−1, 1] throughout; and when the server is killed and started again, the backend
// reports the loss and comes back by itself, with the loop working again.
//
// A machine without jackd FAILS this test with a message saying what to install; only
// PANELBASS_SKIP_JACK=1 skips it.
#include "engine/alsa_backend.h"

#include <gtest/gtest.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "dsp/random.h"
#include "tests/support/jack_server.h"

namespace panelbass::engine {
namespace {

using testing_support::jack_card;
using testing_support::JackServer;
using testing_support::loopback_config;
using testing_support::skip_jack;

using namespace std::chrono_literals;

using testing_support::kDeviceRate;
using testing_support::kPeriod;
// Eight periods (10.7 ms) of slack: jackd without real-time scheduling on a machine busy compiling is
// sometimes descheduled for several milliseconds and then catches up with a burst of cycles.
constexpr int kPeriods = 8;

/// What the device thread saw, period by period, in buffers sized before the run (no allocation there).
struct Recording {
  explicit Recording(std::size_t periods)
      : drive(periods * kPeriod), sensor(periods * kPeriod), epoch(periods, -1) {}
  std::vector<double> drive, sensor;
  std::vector<int> epoch;  // the test's phase when the period was processed
  std::atomic<std::size_t> periods{0};
  std::atomic<int> current_epoch{0};
  std::atomic<double> max_abs_drive{0.0};

  void record(const AlsaBlockView& v) noexcept {
    const std::size_t i = periods.load(std::memory_order_relaxed);
    if (i >= epoch.size()) return;
    std::copy(v.drive.begin(), v.drive.end(), drive.begin() + static_cast<std::ptrdiff_t>(i * kPeriod));
    std::copy(v.sensor.begin(), v.sensor.end(), sensor.begin() + static_cast<std::ptrdiff_t>(i * kPeriod));
    double m = max_abs_drive.load(std::memory_order_relaxed);
    for (const double x : v.drive) m = std::max(m, std::abs(x));
    max_abs_drive.store(m, std::memory_order_relaxed);
    epoch[i] = current_epoch.load(std::memory_order_relaxed);
    periods.store(i + 1, std::memory_order_release);
  }
};

/// The loop's delay over one stretch of a recording: the lag (0..max_lag frames) with the largest
/// cross-correlation of sensor against drive, and how exactly the sensor repeats the drive at that lag.
struct Delay {
  int frames = -1;                ///< -1: too little signal
  double peak_correlation = 0.0;  ///< normalised, 1 = identical
  double max_mismatch = 1.0;      ///< max |sensor[n] − float(drive[n − frames])| over the checked span
  std::size_t checked = 0;        ///< samples compared
  int windows = 0;                ///< windows of the epoch tried (the last the exact one, if any was)
};

/// The delay over the samples [begin, end) of `r`.
Delay measure_delay(const Recording& r, std::size_t begin, std::size_t end, int max_lag) {
  Delay d;
  if (end <= begin + static_cast<std::size_t>(max_lag) * 2 || begin < static_cast<std::size_t>(max_lag)) return d;
  double best = -1.0;
  for (int lag = 0; lag <= max_lag; ++lag) {
    double xy = 0.0, xx = 0.0, yy = 0.0;
    for (std::size_t n = begin; n < end; ++n) {
      const double x = r.drive[n - static_cast<std::size_t>(lag)], y = r.sensor[n];
      xy += x * y;
      xx += x * x;
      yy += y * y;
    }
    const double c = xx > 0.0 && yy > 0.0 ? xy / std::sqrt(xx * yy) : 0.0;
    if (c > best) {
      best = c;
      d.frames = lag;
    }
  }
  d.peak_correlation = best;
  d.max_mismatch = 0.0;
  for (std::size_t n = begin; n < end; ++n) {
    const double expected = static_cast<float>(r.drive[n - static_cast<std::size_t>(d.frames)]);
    d.max_mismatch = std::max(d.max_mismatch, std::abs(r.sensor[n] - expected));
  }
  d.checked = end - begin;
  return d;
}

/// The loop's delay in one epoch's contiguous run of periods, over a window of one second: the first
/// window (after the loop's first 0.25 s of filling, in steps of 0.125 s) where the sensor repeats the
/// drive exactly, else the one that came closest. On a loaded 2-core CI machine the loop through a JACK
/// server without real-time scheduling once slipped inside JACK while the ALSA side saw no xrun
/// (correlation 0.79 over the first second); such a slip spoils the windows around it but not all of
/// them, whereas a backend that loses or repeats samples itself spoils every one.
Delay measure_epoch_delay(const Recording& r, int epoch, int max_lag) {
  const std::size_t periods = r.periods.load(std::memory_order_acquire);
  std::size_t first = periods, last = 0;
  for (std::size_t i = 0; i < periods; ++i) {
    if (r.epoch[i] != epoch) continue;
    first = std::min(first, i);
    last = i + 1;
  }
  Delay best;
  if (first >= last) return best;
  const auto window = static_cast<std::size_t>(kDeviceRate), step = static_cast<std::size_t>(kDeviceRate / 8);
  int windows = 0;
  for (std::size_t begin = first * kPeriod + static_cast<std::size_t>(kDeviceRate / 4);
       begin + window <= last * kPeriod; begin += step) {
    const Delay d = measure_delay(r, begin, begin + window, max_lag);
    ++windows;
    if (windows == 1 || d.max_mismatch < best.max_mismatch) best = d;
    if (d.frames >= 0 && d.max_mismatch < 1e-7) break;
  }
  best.windows = windows;
  return best;
}

/// Waits until `done()` or `timeout`; true if done.
template <class Done>
bool wait_for(Done&& done, std::chrono::milliseconds timeout) {
  for (auto until = std::chrono::steady_clock::now() + timeout; std::chrono::steady_clock::now() < until;) {
    if (done()) return true;
    std::this_thread::sleep_for(5ms);
  }
  return done();
}

std::string describe(const AlsaStatus& s) {
  return std::string("state ") + alsa_state_name(s.state) + ", opens " + std::to_string(s.opens) + ", failed opens " +
         std::to_string(s.failed_opens) + ", losses " + std::to_string(s.losses) + ", xruns " +
         std::to_string(s.xruns) + ", periods " + std::to_string(s.periods) + ", last error \"" +
         s.last_error.data() + "\"";
}

/// A band-pass-only chain at `fs` (the feedback slot passes the sensor's observations by).
ChainOptions chain_options(double fs, int max_block) {
  ChainOptions o;
  o.spec = {fs, max_block};
  return o;
}

TEST(AlsaBackend, JackLoopbackRunsWithoutXrunsAndSurvivesAServerRestart) {
  if (skip_jack()) GTEST_SKIP() << "PANELBASS_SKIP_JACK=1";
  const std::string tag = "pb" + std::to_string(::getpid());
  JackServer server("panelbass-" + std::to_string(::getpid()), kDeviceRate, kPeriod);
  ::setenv("JACK_DEFAULT_SERVER", server.name().c_str(), 1);
  const std::string started = server.start();
  ASSERT_EQ(started, "") << "the JACK dummy server could not be started: " << started;

  Chain chain(chain_options(3000.0, 64));
  Recording rec(static_cast<std::size_t>(12 * kDeviceRate / kPeriod));
  AlsaOptions o = jack_card(loopback_config(tag), kDeviceRate, kPeriod, kPeriods, 0.0);
  o.playback_channels = 2;
  o.drive_channel = 0;
  o.capture_channels = 2;
  o.program_channel = kNoChannel;  // program from the vector below
  o.sensor_channel = 1;            // the loop's return
  o.reopen_min = 20ms;
  o.reopen_max = 200ms;
  o.device_timeout = 300ms;
  dsp::Rng rng(7);  // 1 s of noise, looped
  for (double& x : o.program) x = rng.uniform(-0.9, 0.9);
  o.on_block = [&rec](const AlsaBlockView& v) { rec.record(v); };
  {
    // A rate the server does not run at is refused, and the status says what the device offers.
    AlsaOptions wrong = o;
    wrong.rate = Hertz{44100.0};
    wrong.on_block = nullptr;
    AlsaBackend refused(chain, wrong);
    refused.start();
    EXPECT_TRUE(wait_for([&] { return refused.status().failed_opens >= 1; }, 3s)) << describe(refused.status());
    refused.stop();
    EXPECT_NE(std::string(refused.status().last_error.data()).find("rate 44100 Hz refused (the device offers 48000..48000 Hz)"),
              std::string::npos)
        << describe(refused.status());
    EXPECT_EQ(refused.status().opens, 0u);
  }
  AlsaBackend backend(chain, o);
  const RateBridgeLatency resampling = backend.resampling_latency();

  // Phase 0: two and a half seconds of streaming at the server's pace.
  backend.start();
  ASSERT_TRUE(wait_for([&] { return backend.status().periods > 50; }, 5s))
      << "the backend never streamed (the PCMs are of type jack: is libasound2-plugins installed?): "
      << describe(backend.status()) << "\njackd:\n" << server.log();
  std::this_thread::sleep_for(2500ms);
  const AlsaStatus before = backend.status();
  const std::uint64_t xruns_before = chain.metrics().snapshot().xruns;
  EXPECT_EQ(before.state, AlsaState::running) << describe(before);
  EXPECT_EQ(before.xruns, 0u) << describe(before);
  EXPECT_EQ(xruns_before, 0u);
  EXPECT_EQ(before.opens, 1u) << describe(before);

  // Phase 1: the server goes away; the backend reports the loss and keeps trying.
  rec.current_epoch.store(1);
  server.stop();
  EXPECT_TRUE(wait_for([&] { return backend.status().losses >= 1; }, 3s)) << describe(backend.status());
  const AlsaStatus lost = backend.status();
  EXPECT_NE(lost.state, AlsaState::running) << describe(lost);
  EXPECT_STRNE(lost.last_error.data(), "") << describe(lost);
  std::this_thread::sleep_for(300ms);  // a few failed reopen attempts while the server is down
  EXPECT_GE(backend.status().failed_opens, 1u) << describe(backend.status());

  // Phase 2: the server is back; so is the backend, with the loop working again.
  const std::string restarted = server.start();
  ASSERT_EQ(restarted, "") << "the JACK dummy server could not be restarted: " << restarted;
  const std::uint64_t periods_at_restart = backend.status().periods;
  EXPECT_TRUE(wait_for([&] {
    const AlsaStatus s = backend.status();
    return s.opens >= 2 && s.state == AlsaState::running && s.periods > periods_at_restart + 50;
  }, 5s)) << describe(backend.status()) << "\njackd:\n" << server.log();
  std::this_thread::sleep_for(2000ms);
  const AlsaStatus after = backend.status();
  backend.stop();
  server.stop();
  EXPECT_EQ(backend.status().state, AlsaState::stopped);

  const Delay first = measure_epoch_delay(rec, 0, 2048), second = measure_epoch_delay(rec, 1, 2048);
  std::printf("[ loopback ] JACK dummy 48 kHz/64, ALSA period %d x %d, chain at 3000 Hz: loop delay %d frames "
              "(%.3f ms) before the restart (one-second windows tried: %d), %d frames after (%d); resampling latency %d frames (%.3f ms); "
              "device thread real-time: %s; %s\n",
              kPeriod, kPeriods, first.frames, 1e3 * first.frames / kDeviceRate, first.windows, second.frames,
              second.windows, resampling.total_samples,
              resampling.total_ms, after.realtime ? "yes" : "no", describe(after).c_str());
  // The delay is found, and the loop returns every drive sample exactly.
  ASSERT_GE(first.frames, 0) << "no signal in the first run";
  EXPECT_GT(first.peak_correlation, 0.999);
  EXPECT_LT(first.max_mismatch, 1e-7) << "over " << first.checked << " samples, the closest of " << first.windows << " windows";
  // The backend keeps the playback buffer full ahead of the capture: the loop's delay is one buffer
  // plus whatever the capture had queued when the first period was read (none unless that read was late).
  constexpr int kBuffer = kPeriods * kPeriod;
  EXPECT_GE(first.frames, kBuffer);
  EXPECT_LE(first.frames, 2 * kBuffer);
  ASSERT_GE(second.frames, 0) << "no signal after the restart";
  EXPECT_GT(second.peak_correlation, 0.999);
  EXPECT_LT(second.max_mismatch, 1e-7) << "over " << second.checked << " samples, the closest of " << second.windows << " windows";
  EXPECT_GE(second.frames, kBuffer);
  EXPECT_LE(second.frames, 2 * kBuffer);
  // The drive stayed in [−1, 1] all along; the restart came back at least once.
  EXPECT_LE(rec.max_abs_drive.load(), 1.0);
  EXPECT_GT(rec.max_abs_drive.load(), 0.05);  // and the program really drove it
  EXPECT_GE(after.reopens(), 1u) << describe(after);
  EXPECT_GE(after.losses, 1u) << describe(after);
}

TEST(AlsaBackend, JackMeasurementPlaysInPlaceOfTheChainAndFindsTheRoundTrip) {
  // A measurement on the loopback: channel 1 hears the drive, as sensor and as loopback. Independent
  // expectations: the measurement's samples reach the chain-rate drive verbatim (the chain bypassed); the
  // round trip the calibration finds at 3000 Hz is the loop's own delay found at 48 kHz on the device-rate
  // recording plus the rate bridge's latency (its impulse's centre of mass), within one sample; no xrun; and
  // the program plays again afterwards.
  if (skip_jack()) GTEST_SKIP() << "PANELBASS_SKIP_JACK=1";
  const std::string tag = "pm" + std::to_string(::getpid());
  JackServer server("panelbass-m" + std::to_string(::getpid()), kDeviceRate, kPeriod);
  const std::string started = server.start_as_default();
  ASSERT_EQ(started, "") << started;

  Chain chain(chain_options(3000.0, 64));
  Recording rec(static_cast<std::size_t>(6 * kDeviceRate / kPeriod));
  AlsaOptions o = jack_card(loopback_config(tag), kDeviceRate, kPeriod, kPeriods, 0.3);
  o.sensor_channel = 1;
  o.loopback_channel = 1;
  // The chain-rate drive, as the device thread produced it, in a buffer sized before the run.
  std::vector<double> model_drive(static_cast<std::size_t>(6 * 3000), 0.0);
  std::atomic<std::size_t> model_n{0};
  o.on_block = [&](const AlsaBlockView& v) {
    rec.record(v);
    std::size_t n = model_n.load(std::memory_order_relaxed);
    for (const double x : v.model_drive) {
      if (n < model_drive.size()) model_drive[n++] = x;
    }
    model_n.store(n, std::memory_order_release);
  };
  AlsaBackend backend(chain, o);
  backend.start();
  ASSERT_TRUE(wait_for([&] { return backend.status().periods > 200; }, 5s)) << describe(backend.status());

  dsp::Rng rng(3);
  std::vector<double> drive(4500, 0.0);  // 1.2 s of noise, then 0.3 s of silence for the round trip
  for (std::size_t k = 0; k < 3600; ++k) drive[k] = rng.uniform(-0.5, 0.5);
  Measurement m(drive, 60);
  EXPECT_THROW(Measurement({1.5}, 10), std::invalid_argument);
  const Measurement::State state = backend.measure(m, 10s);
  ASSERT_EQ(state, Measurement::State::finished) << describe(backend.status());
  const std::uint64_t blocks_after = chain.metrics().snapshot().blocks;
  std::this_thread::sleep_for(300ms);
  EXPECT_GT(chain.metrics().snapshot().blocks, blocks_after) << "the chain plays again";
  backend.stop();
  server.stop();
  EXPECT_EQ(backend.status().xruns, 0u) << describe(backend.status());

  // The chain bypassed: the measurement's samples appear in the chain-rate drive exactly.
  const std::size_t n = model_n.load(std::memory_order_acquire);
  std::size_t at = n;
  for (std::size_t k = 0; k + drive.size() <= n && at == n; ++k) {
    if (model_drive[k] == drive[0] && std::equal(drive.begin(), drive.end(), model_drive.begin() + static_cast<std::ptrdiff_t>(k))) at = k;
  }
  EXPECT_LT(at, n) << "the measurement's drive never reached the chain-rate output verbatim";

  const Eigen::VectorXd played = Eigen::Map<const Eigen::VectorXd>(m.drive().data(), static_cast<Eigen::Index>(drive.size()));
  const auto& heard_v = m.captured(MeasuredChannel::loopback);
  const Eigen::VectorXd heard = Eigen::Map<const Eigen::VectorXd>(heard_v.data(), static_cast<Eigen::Index>(heard_v.size()));
  const RoundTrip trip = find_round_trip(played, heard, 800);
  const Delay loop = measure_epoch_delay(rec, 0, 2048);
  ASSERT_GE(loop.frames, 0);
  const double expected = (loop.frames + backend.resampling_latency().total_ms * kDeviceRate / 1e3) * 3000.0 / kDeviceRate;
  std::printf("[ measurement ] round trip %d samples at 3000 Hz (%.2f refined, %.3f ms; correlation %.4f); the loop "
              "%d frames at 48 kHz + the bridge's %.3f ms = %.2f samples\n",
              trip.samples, trip.fractional, 1e3 * trip.fractional / 3000.0, trip.peak, loop.frames,
              backend.resampling_latency().total_ms, expected);
  EXPECT_GT(trip.peak, 0.5);  // the bridge passes 0..1200 Hz of the drive's 0..1500 Hz, minimum-phase
  EXPECT_NEAR(trip.fractional, expected, 1.0);
}

TEST(AlsaBackend, PlaybackOnlyAtTheChainsOwnRateIsPacedByTheDevice) {
  // No capture, no rate bridge: the chain runs at 48 kHz, paced by room in the playback buffer, with
  // S16/S32/float conversion as the device asks (float for JACK) and the drive on channel 1 of 2.
  if (skip_jack()) GTEST_SKIP() << "PANELBASS_SKIP_JACK=1";
  JackServer server("panelbass-" + std::to_string(::getpid()) + "-p", kDeviceRate, kPeriod);
  ::setenv("JACK_DEFAULT_SERVER", server.name().c_str(), 1);
  const std::string started = server.start();
  ASSERT_EQ(started, "") << "the JACK dummy server could not be started: " << started;
  Chain chain(chain_options(kDeviceRate, kPeriod));
  const std::string tag = "pq" + std::to_string(::getpid());
  AlsaOptions o = jack_card(loopback_config(tag), kDeviceRate, kPeriod, kPeriods, 0.5, 100.0);
  o.capture_device = "";
  o.drive_channel = 1;
  std::atomic<double> max_abs{0.0};
  std::atomic<std::size_t> model_samples{0};
  o.on_block = [&](const AlsaBlockView& v) {
    double m = max_abs.load(std::memory_order_relaxed);
    for (const double x : v.drive) m = std::max(m, std::abs(x));
    max_abs.store(m, std::memory_order_relaxed);
    model_samples.fetch_add(v.model_drive.size(), std::memory_order_relaxed);
  };
  AlsaBackend backend(chain, o);
  EXPECT_EQ(backend.resampling_latency().total_samples, 0);
  const auto t0 = std::chrono::steady_clock::now();
  backend.start();
  ASSERT_TRUE(wait_for([&] { return backend.status().periods > 50; }, 5s))
      << "the backend never streamed (the PCMs are of type jack: is libasound2-plugins installed?): "
      << describe(backend.status()) << "\njackd:\n" << server.log();
  std::this_thread::sleep_for(1s);
  const AlsaStatus s = backend.status();
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  backend.stop();
  server.stop();
  EXPECT_EQ(s.xruns, 0u) << describe(s);
  EXPECT_EQ(s.opens, 1u) << describe(s);
  // Without a bridge the chain sees exactly the device's frames, one period per block.
  EXPECT_EQ(model_samples.load(), static_cast<std::size_t>(backend.status().periods) * kPeriod);
  // Paced by the device, not free-running (which would be hundreds of times faster): no more periods
  // than the elapsed audio time holds, with a factor 2 for a server catching up after a stall.
  EXPECT_LE(static_cast<double>(s.periods), 2.0 * elapsed * kDeviceRate / kPeriod) << describe(s);
  EXPECT_LE(max_abs.load(), 1.0);
  EXPECT_GT(max_abs.load(), 0.1);
}

TEST(AlsaBackend, AMissingDeviceIsRetriedWithBackOffAndStopsPromptly) {
  // No JACK needed: a PCM type that does not exist fails to open, again and again.
  Chain chain(chain_options(3000.0, 64));
  AlsaOptions o;
  o.playback_device = "nowhere";
  o.capture_device = "";
  o.config_text = "pcm.nowhere { type panelbass_no_such_plugin }\n";
  o.reopen_min = 10ms;
  o.reopen_max = 40ms;
  AlsaBackend backend(chain, o);
  backend.start();
  EXPECT_TRUE(wait_for([&] { return backend.status().failed_opens >= 3; }, 3s)) << describe(backend.status());
  const AlsaStatus s = backend.status();
  EXPECT_EQ(s.opens, 0u);
  EXPECT_NE(std::string(s.last_error.data()).find("playback nowhere: cannot open"), std::string::npos) << describe(s);
  backend.stop();  // a stop that hung would hang the test, which ctest reports
  EXPECT_EQ(backend.status().state, AlsaState::stopped);
}

TEST(AlsaBackend, BadOptionsAreNamed) {
  Chain chain(chain_options(3000.0, 64)), small_chain(chain_options(3000.0, 4));
  const auto message = [&chain](const AlsaOptions& o) {
    try {
      AlsaBackend backend(chain, o);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  AlsaOptions o;
  o.playback_device = "";
  o.capture_device = "";
  EXPECT_NE(message(o).find("neither a playback nor a capture device"), std::string::npos) << message(o);
  o = {};
  o.drive_channel = 2;
  EXPECT_NE(message(o).find("drive_channel must be within [0, 1]"), std::string::npos) << message(o);
  o = {};
  o.sensor_channel = 0;
  EXPECT_NE(message(o).find("sensor_channel is set but no capture device"), std::string::npos) << message(o);
  o = {};
  o.capture_device = "x";
  o.program_channel = 5;
  EXPECT_NE(message(o).find("program_channel must be within [0, 1] or none"), std::string::npos) << message(o);
  o = {};
  o.periods = 1;
  EXPECT_NE(message(o).find("periods must be within [2, 64]"), std::string::npos) << message(o);
  o = {};
  o.config_text = "pcm.broken { type ";
  EXPECT_NE(message(o).find("config_text does not parse"), std::string::npos) << message(o);
  const auto small_message = [&small_chain](const AlsaOptions& o) {
    try {
      AlsaBackend backend(small_chain, o);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  o = {};  // 64 frames at 48 kHz are 4 samples at 3000 Hz, up to 12 in one period; the chain takes 4
  EXPECT_NE(small_message(o).find("more than the chain's max_block 4"), std::string::npos) << small_message(o);
  o = {};
  o.rate = Hertz{3000.0};
  o.period = Samples{8};
  EXPECT_NE(small_message(o).find("period 8 exceeds the chain's max_block 4"), std::string::npos) << small_message(o);
  o = {};
  o.reopen_max = std::chrono::milliseconds{1};
  EXPECT_NE(message(o).find("reopen_min <= reopen_max"), std::string::npos) << message(o);
}

}  // namespace
}  // namespace panelbass::engine

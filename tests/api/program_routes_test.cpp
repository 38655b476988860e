// GET/PUT /api/program: the program the engine loops, replaced while it plays. On the virtual transducer and
// on a sound card (the JACK dummy, tests/support/jack_server.h), the drive the chain plays changes to the new
// sine once the fade is over; bad requests are refused naming the field; a card whose program comes from its
// capture refuses a program from memory; the request guard treats the route as the other state changes.
//
// Independent expectations: the frequency of the played drive, measured from the drive itself by
// dsp::sine_frequency (a least-squares sinusoid; it finds none in the noise that played before), is the
// requested one — 80 Hz and 200 Hz loop exactly at 3000 and 48000 Hz (whole periods in whole samples), and
// the chain without models (band-pass and limiter below its knee) is linear, so it changes no frequency.
// A machine without jackd FAILS the card's test with a message saying what to install; only
// PANELBASS_SKIP_JACK=1 skips it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <complex>
#include <limits>
#include <numbers>
#include <span>

#include "dsp/sine_fit.h"
#include "tests/api/server_fixture.h"
#include "tests/support/jack_server.h"

namespace panelbass::api::api_testing {
namespace {

/// Copies `length` samples of a stream, from a sample chosen by the test, on the audio thread without
/// allocating, locking or waiting; the test reads them once `full` is set.
class StreamTap {
 public:
  explicit StreamTap(std::size_t length) : samples_(length) {}
  /// Audio thread: the stream's next samples.
  void offer(std::span<const double> x) noexcept {
    const std::uint64_t seen = seen_.load(std::memory_order_relaxed);
    const std::uint64_t from = from_.load(std::memory_order_acquire);
    for (std::size_t k = 0; k < x.size(); ++k) {
      const std::uint64_t index = seen + k;
      if (index < from || index - from >= samples_.size()) continue;
      samples_[index - from] = x[k];
      if (index - from == samples_.size() - 1) full_.store(true, std::memory_order_release);
    }
    seen_.store(seen + x.size(), std::memory_order_release);
  }
  /// Test thread: the `length` samples that follow from now on (empty if they take longer than 20 s).
  Eigen::VectorXd next() {
    full_.store(false, std::memory_order_relaxed);
    from_.store(seen_.load(std::memory_order_acquire) + 64, std::memory_order_release);
    for (const auto until = std::chrono::steady_clock::now() + 20s; !full_.load(std::memory_order_acquire);) {
      if (std::chrono::steady_clock::now() > until) return {};
      std::this_thread::sleep_for(10ms);
    }
    return Eigen::Map<const Eigen::VectorXd>(samples_.data(), static_cast<Eigen::Index>(samples_.size()));
  }

 private:
  std::vector<double> samples_;
  std::atomic<std::uint64_t> seen_{0};
  std::atomic<std::uint64_t> from_{std::numeric_limits<std::uint64_t>::max()};
  std::atomic<bool> full_{false};
};

class ProgramRouteTest : public ServerTest {
 protected:
  // The server's audio thread writes into tap_: it stops before the tap goes, whatever ended the test.
  void TearDown() override {
    client_.reset();
    server_.reset();
  }

  /// PUT /api/program `body`, then waits (at most 10 s) until the new program has been faded in.
  Reply put_program_and_settle(const nlohmann::json& body) {
    const Reply r = put("/api/program", body);
    for (const auto until = std::chrono::steady_clock::now() + 10s; std::chrono::steady_clock::now() < until;) {
      if (get("/api/program").body.value("settled", false)) break;
      std::this_thread::sleep_for(10ms);
    }
    return r;
  }

  StreamTap tap_{3000};  // one second at the chain's rate
};

TEST_F(ProgramRouteTest, TheDrivePlaysTheNewSineOnceTheFadeIsOver) {
  ServerOptions o = options(dir_ / "store");
  o.engine.on_block = [this](const engine::BlockView& b) { tap_.offer(b.drive); };
  start(std::move(o));

  const Reply before = get("/api/program");
  ASSERT_EQ(before.status, 200) << before.text;
  EXPECT_EQ(before.body["signal"], "custom") << "the fixture's own noise";
  EXPECT_EQ(before.body["source"], "memory");
  EXPECT_EQ(before.body["rate"], 3000.0);
  const Eigen::VectorXd noise = tap_.next();
  ASSERT_EQ(noise.size(), 3000);
  EXPECT_FALSE(dsp::sine_frequency(noise, 3000.0)) << "noise plays before";

  for (const double hz : {80.0, 200.0}) {
    const Reply r = put_program_and_settle({{"signal", "sine:" + std::to_string(static_cast<int>(hz))}, {"amplitude", 0.2}});
    ASSERT_EQ(r.status, 200) << r.text;
    EXPECT_EQ(r.body["frequency_hz"], hz);
    EXPECT_EQ(r.body["amplitude"], 0.2);
    const Reply now = get("/api/program");
    EXPECT_TRUE(now.body["settled"].get<bool>()) << now.text;
    EXPECT_EQ(now.body["signal"], r.body["signal"]);
    const Eigen::VectorXd drive = tap_.next();
    ASSERT_EQ(drive.size(), 3000);
    const std::optional<double> played = dsp::sine_frequency(drive, 3000.0);
    ASSERT_TRUE(played) << "the drive is one sine after the fade";
    EXPECT_NEAR(*played, hz, 1e-3 * hz);
    EXPECT_GT(drive.cwiseAbs().maxCoeff(), 0.1);
  }

  // Noise with a seed, then silence: what plays is said back.
  Reply r = put_program_and_settle({{"signal", "noise"}, {"amplitude", 0.1}, {"seed", 9}});
  ASSERT_EQ(r.status, 200) << r.text;
  EXPECT_EQ(r.body["seed"], 9);
  EXPECT_FALSE(dsp::sine_frequency(tap_.next(), 3000.0));
  r = put_program_and_settle({{"signal", "silence"}});
  ASSERT_EQ(r.status, 200) << r.text;
  EXPECT_EQ(r.body["amplitude"], 0.0);
  // Only the band-pass's tail of the noise is left (its 20 Hz high-pass rings down over tens of ms).
  EXPECT_LT(tap_.next().cwiseAbs().maxCoeff(), 1e-4);
}

// The A/B a listener makes: the controllers' bypass flags (PATCH /api/config) switch between the chain with its
// feedforward and without, on the program PUT /api/program plays. Expectation: the controller
// u*(k) = u(k) + 0.5·u(k−1) scales an 80 Hz sine by |1 + 0.5·e^(−jω)|, ω = 2π·80/3000, and bypassed by 1.
TEST_F(ProgramRouteTest, TheBypassFlagsGiveTheAB) {
  ServerOptions o = options(dir_ / "store");
  o.engine.on_block = [this](const engine::BlockView& b) { tap_.offer(b.drive); };
  start(std::move(o));
  const std::string lq = upload(lq_gain_controller(0.5));
  ASSERT_EQ(post("/api/models/" + lq + "/activate", std::string()).status, 200);
  ASSERT_EQ(put_program_and_settle({{"signal", "sine:80"}, {"amplitude", 0.2}}).status, 200);
  const auto fundamental = [this] {
    const Eigen::VectorXd drive = tap_.next();
    const Eigen::Vector3d abc = dsp::fit_sine(drive, 3000.0, 80.0).coefficients;
    return std::hypot(abc[0], abc[1]);
  };
  const double with_controller = fundamental();
  ASSERT_EQ(patch("/api/config", R"({"feedforward":{"bypass":true}})").status, 200);
  std::this_thread::sleep_for(100ms);  // the bypass ramps over the crossfade (20 ms)
  const double bypassed = fundamental();
  ASSERT_EQ(patch("/api/config", R"({"feedforward":{"bypass":false}})").status, 200);
  std::this_thread::sleep_for(100ms);
  const double again = fundamental();
  const double w = 2.0 * std::numbers::pi * 80.0 / 3000.0;
  const double gain = std::abs(1.0 + 0.5 * std::polar(1.0, -w));
  EXPECT_NEAR(with_controller / bypassed, gain, 0.01 * gain);
  EXPECT_NEAR(again / bypassed, gain, 0.01 * gain);
}

TEST_F(ProgramRouteTest, BadRequestsAreRefusedNamingTheField) {
  start();
  const auto refused = [this](const nlohmann::json& body, const std::string& field) {
    const Reply r = put("/api/program", body);
    EXPECT_EQ(r.status, 400) << body.dump() << " " << r.text;
    EXPECT_NE(error_message(r).find(field), std::string::npos) << body.dump() << " " << r.text;
  };
  refused({{"signal", "square"}}, "program.signal");
  refused({{"signal", "sine:abc"}}, "program.signal");
  refused({{"signal", "sine:0"}}, "program.signal");
  refused({{"signal", "sine:1500"}}, "program.signal");  // half the rate: it would alias
  refused({{"signal", "sine:-80"}}, "program.signal");
  refused({{"signal", "sine:1e-300"}}, "program.signal");  // a loop of one period would not fit in memory
  refused({{"signal", "sine:nan"}}, "program.signal");
  refused({{"signal", 80}}, "program.signal");
  refused({{"amplitude", 0.2}}, "program.signal");
  refused({{"signal", "sine:80"}, {"amplitude", 1.5}}, "program.amplitude");
  refused({{"signal", "sine:80"}, {"amplitude", -0.1}}, "program.amplitude");
  refused({{"signal", "sine:80"}, {"amplitude", "loud"}}, "program.amplitude");
  refused({{"signal", "sine:80"}, {"seed", 3}}, "program.seed");
  refused({{"signal", "noise"}, {"seed", -3}}, "program.seed");
  refused({{"signal", "noise"}, {"gain", 3}}, "program.gain");
  refused(nlohmann::json::array({1}), "program");
  // Nothing of it reached the engine.
  EXPECT_EQ(get("/api/program").body["signal"], "custom");

  // A state change like the others: another origin may not, a browser's body must be JSON.
  httplib::Headers foreign = {{"Origin", "http://elsewhere.example"}};
  const Reply cross = reply_of(client_->Put("/api/program", foreign, R"({"signal":"silence"})", "application/json"));
  EXPECT_EQ(cross.status, 403) << cross.text;
  httplib::Headers own = {{"Origin", "http://127.0.0.1:" + std::to_string(port_)}};
  const Reply text = reply_of(client_->Put("/api/program", own, R"({"signal":"silence"})", "text/plain"));
  EXPECT_EQ(text.status, 415) << text.text;
  const Reply ok = reply_of(client_->Put("/api/program", own, R"({"signal":"silence"})", "application/json"));
  EXPECT_EQ(ok.status, 200) << ok.text;
}

// On the card (the JACK dummy at 48 kHz): the program is made at the card's rate, the chain's drive changes to
// it, the card's safe level bounds it; a card whose program comes from a capture channel refuses one from memory.
TEST_F(ProgramRouteTest, OnACardTheDrivePlaysTheNewSineAndAProgramFromTheCaptureIsNotReplaced) {
  if (testing_support::skip_jack()) GTEST_SKIP() << "PANELBASS_SKIP_JACK=1";
  const std::string tag = "pbp" + std::to_string(::getpid());
  testing_support::JackServer jack("panelbass-program-" + std::to_string(::getpid()), testing_support::kDeviceRate,
                                   testing_support::kPeriod);
  const std::string started = jack.start();
  ASSERT_EQ(started, "") << started;
  ::setenv("JACK_DEFAULT_SERVER", jack.name().c_str(), 1);

  ServerOptions o = options(dir_ / "store");
  o.engine.program.clear();
  engine::AlsaOptions card = testing_support::jack_card(testing_support::loopback_config(tag), testing_support::kDeviceRate,
                                                        testing_support::kPeriod, 8, 0.2);
  card.realtime_priority = 0;
  card.sensor_channel = 1;
  card.on_block = [this](const engine::AlsaBlockView& b) { tap_.offer(b.model_drive); };
  o.engine.alsa = card;
  o.engine.safe_level = 0.5;
  start(std::move(o));

  const Reply before = get("/api/program");
  EXPECT_EQ(before.body["rate"], 48000.0) << before.text;
  const Reply r = put_program_and_settle({{"signal", "sine:80"}, {"amplitude", 0.3}});
  ASSERT_EQ(r.status, 200) << r.text;
  EXPECT_EQ(r.body["frequency_hz"], 80.0);
  // An xrun on a loaded machine restarts the streams (a gap in the drive): up to three seconds are read for one
  // without — a program that never changed gives no 80 Hz sine in any of them.
  Eigen::VectorXd drive;
  std::optional<double> played;
  for (int attempt = 0; attempt < 3 && !played; ++attempt) {
    drive = tap_.next();
    ASSERT_EQ(drive.size(), 3000) << "the card did not stream; jackd:\n" << jack.log();
    played = dsp::sine_frequency(drive, 3000.0);
  }
  ASSERT_TRUE(played) << "the drive is one sine after the fade";
  EXPECT_NEAR(*played, 80.0, 0.08);
  EXPECT_NEAR(drive.cwiseAbs().maxCoeff(), 0.3, 0.03) << "the chain without models passes 80 Hz near unity";

  const Reply loud = put("/api/program", {{"signal", "sine:80"}, {"amplitude", 0.6}});
  EXPECT_EQ(loud.status, 400) << loud.text;
  EXPECT_NE(error_message(loud).find("safe level"), std::string::npos) << loud.text;
  EXPECT_NE(error_message(loud).find("program.amplitude"), std::string::npos) << loud.text;

  // The program from the card's capture (channel 0): nothing to replace from memory.
  ServerOptions captured = options(dir_ / "store2");
  engine::AlsaOptions from_capture = testing_support::jack_card(testing_support::loopback_config(tag + "x"),
                                                                testing_support::kDeviceRate, testing_support::kPeriod, 8, 0.0);
  from_capture.realtime_priority = 0;
  from_capture.program.clear();
  from_capture.program_channel = 0;
  captured.engine.alsa = from_capture;
  start(std::move(captured));
  const Reply refused = put("/api/program", {{"signal", "sine:80"}, {"amplitude", 0.2}});
  EXPECT_EQ(refused.status, 409) << refused.text;
  EXPECT_NE(error_message(refused).find("capture"), std::string::npos) << refused.text;
  const Reply source = get("/api/program");
  EXPECT_EQ(source.body["source"], "capture") << source.text;
  EXPECT_EQ(source.body["channel"], 0);
  server_->stop();
}

}  // namespace
}  // namespace panelbass::api::api_testing

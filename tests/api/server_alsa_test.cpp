// The server on a sound card: `panelbass serve --backend alsa` through real libasound calls. The test
// starts a JACK server with the dummy driver and serves on two ALSA PCMs of type "jack" wired as a loopback
// (tests/support/jack_server.h), then kills the JACK server — the card disappears — and starts it again.
//
// Independent expectations: while the card streams, /api/status says so ("device.state": "running") and
// /metrics has panelbass_device_up 1; once the JACK server is gone the status reports the loss
// (losses ≥ 1, state "reopening", the error text) and the gauge drops to 0; after the server is back
// the backend reopens by itself (reopens ≥ 1, streaming again, blocks advancing) with no restart of
// panelbass; the drive stays within [−1, 1] throughout; and a job that would excite the transducer beyond
// the card's safe level is refused at submission with a message saying why.
//
// A machine without jackd FAILS this test with a message saying what to install; only
// PANELBASS_SKIP_JACK=1 skips it.
#include "api/server.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <functional>
#include <string>
#include <thread>

#include <httplib.h>

#include "models/plant/plant_presets.h"
#include "tests/support/jack_server.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::api {
namespace {

using namespace std::chrono_literals;

using testing_support::kDeviceRate;
using testing_support::kPeriod;

class ServerOnACardTest : public testing_support::ScratchDirectoryTest {
 protected:
  nlohmann::json get_json(const std::string& path) {
    const httplib::Result r = client_->Get(path.c_str());
    if (!r || r->status != 200) return nullptr;
    return nlohmann::json::parse(r->body, nullptr, false);
  }
  std::string get_text(const std::string& path) {
    const httplib::Result r = client_->Get(path.c_str());
    return r && r->status == 200 ? r->body : "";
  }
  // Polls /api/status until `ready` holds for its "engine" object (at most `timeout`); the last status.
  nlohmann::json await_engine(const std::function<bool(const nlohmann::json&)>& ready, std::chrono::seconds timeout) {
    nlohmann::json status;
    for (const auto until = std::chrono::steady_clock::now() + timeout; std::chrono::steady_clock::now() < until;) {
      status = get_json("/api/status");
      if (status.is_object() && ready(status["engine"])) return status;
      std::this_thread::sleep_for(50ms);
    }
    return status;
  }

  std::unique_ptr<Server> server_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(ServerOnACardTest, TheCardGoingAwayShowsInStatusAndMetricsAndItComesBackByItself) {
  if (testing_support::skip_jack()) GTEST_SKIP() << "PANELBASS_SKIP_JACK=1";
  const std::string tag = "pbs" + std::to_string(::getpid());
  testing_support::JackServer jack("panelbass-serve-" + std::to_string(::getpid()), kDeviceRate, kPeriod);
  const std::string started = jack.start();
  ASSERT_EQ(started, "") << started;
  ::setenv("JACK_DEFAULT_SERVER", jack.name().c_str(), 1);

  ServerOptions o;
  o.port = 0;
  o.store = dir_ / "store";
  o.engine.plant = models::plant_preset("panel-exciter");
  o.engine.chain.fs = o.engine.plant.fs;
  engine::AlsaOptions card = testing_support::jack_card(testing_support::loopback_config(tag), kDeviceRate, kPeriod, 8, 0.4);
  card.realtime_priority = 0;  // as before: at normal priority, the buffer's slack has to do
  card.sensor_channel = 1;
  card.reopen_min = 50ms;
  card.reopen_max = 400ms;
  o.engine.alsa = card;
  server_ = std::make_unique<Server>(std::move(o));
  client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->start());
  client_->set_read_timeout(10, 0);

  const auto streaming = [](const nlohmann::json& e) { return e["device"]["state"] == "running"; };
  nlohmann::json status = await_engine(streaming, 10s);
  ASSERT_TRUE(status.is_object()) << "no status";
  EXPECT_EQ(status["engine"]["backend"], "alsa");
  ASSERT_EQ(status["engine"]["device"]["state"], "running") << status.dump() << "\njackd:\n" << jack.log();
  EXPECT_NE(get_text("/metrics").find("\npanelbass_device_up 1\n"), std::string::npos) << get_text("/metrics");

  // A job excites through the card, within its safe level: beyond it, refused at submission, saying why.
  const httplib::Result job = client_->Post("/api/jobs", R"({"kind":"excite","params":{"amplitude":0.9}})", "application/json");
  ASSERT_TRUE(job);
  EXPECT_EQ(job->status, 400) << job->body;
  EXPECT_NE(job->body.find("safe level"), std::string::npos) << job->body;

  // The card disappears.
  jack.stop();
  status = await_engine([](const nlohmann::json& e) { return e["device"]["losses"].get<int>() >= 1; }, 10s);
  const nlohmann::json lost = status["engine"]["device"];
  ASSERT_GE(lost["losses"].get<int>(), 1) << status.dump();
  EXPECT_NE(lost["state"], "running") << status.dump();
  EXPECT_NE(lost["last_error"].get<std::string>(), "") << status.dump();
  EXPECT_EQ(status["engine"]["state"], "running") << "the service keeps going without its card";
  EXPECT_NE(get_text("/metrics").find("\npanelbass_device_up 0\n"), std::string::npos) << get_text("/metrics");

  // It comes back.
  ASSERT_EQ(jack.start(), "");
  status = await_engine([](const nlohmann::json& e) { return e["device"]["state"] == "running" &&
                                                           e["device"]["reopens"].get<int>() >= 1; }, 15s);
  ASSERT_EQ(status["engine"]["device"]["state"], "running") << status.dump() << "\njackd:\n" << jack.log();
  EXPECT_GE(status["engine"]["device"]["reopens"].get<int>(), 1);
  const std::uint64_t blocks = status["metrics"]["blocks"].get<std::uint64_t>();
  std::this_thread::sleep_for(300ms);
  status = get_json("/api/status");
  EXPECT_GT(status["metrics"]["blocks"].get<std::uint64_t>(), blocks) << "the chain plays again";
  EXPECT_LE(status["metrics"]["peak_drive"].get<double>(), 1.0);
  EXPECT_GT(status["metrics"]["peak_drive"].get<double>(), 0.1) << "the program reached the drive";
  const std::string metrics = get_text("/metrics");
  EXPECT_NE(metrics.find("\npanelbass_device_up 1\n"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("\npanelbass_device_reopens_total "), std::string::npos) << metrics;
  server_->stop();
}

}  // namespace
}  // namespace panelbass::api

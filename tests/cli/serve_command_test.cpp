// `panelbass serve` as a user runs it: a port another server holds is an error naming the address (exit 1;
// the two never share it), and the start-up demo designs its LQ feedforward for the program it plays, so that
// the status shows a program within the chain's safe amplitude.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <regex>
#include <string>
#include <thread>

#include "api/server.h"
#include "models/plant/plant_presets.h"
#include "tests/support/cli_runner.h"

// After the project's (Eigen) headers: glibc's resolv.h, which httplib pulls in, defines a macro `_res`.
#include <httplib.h>

namespace panelbass {
namespace {

using namespace testing_support;
using namespace std::chrono_literals;

// Runs `panelbass serve` in the background when asked (start_serve), stopped by SIGTERM when the test ends.
class CliServe : public CliTest {
 protected:
  ~CliServe() override {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    // It stops within a block or two; wait for that (its folder is removed next).
    for (int k = 0; k < 200 && ::kill(pid_, 0) == 0 && !zombie(); ++k) std::this_thread::sleep_for(50ms);
  }

  /// Starts `panelbass serve <args>` in the background, its output in files of the test's folder.
  void start_serve(const std::string& args) {
    const std::string command = quoted(std::string(PANELBASS_BIN)) + " serve " + args + " </dev/null >" +
                                quoted(dir_ / "serve-out.txt") + " 2>" + quoted(dir_ / "serve-err.txt") + " & echo $! >" +
                                quoted(dir_ / "serve.pid");
    ASSERT_EQ(std::system(command.c_str()), 0);
    std::ifstream(dir_ / "serve.pid") >> pid_;
  }

  /// The port from the first line it prints ("panelbass: serving http://127.0.0.1:PORT/ …"), waiting up to
  /// 30 s; -1 if none came.
  int serve_port() const {
    const std::regex serving(R"(serving http://127\.0\.0\.1:(\d+)/)");
    for (int k = 0; k < 600; ++k) {
      std::smatch m;
      const std::string text = text_of(dir_ / "serve-out.txt");
      if (std::regex_search(text, m, serving)) return std::stoi(m[1]);
      std::this_thread::sleep_for(50ms);
    }
    return -1;
  }

  /// What it wrote on stderr so far.
  std::string serve_err() const { return text_of(dir_ / "serve-err.txt"); }

  /// Options of a server run in the test's own process (any free port, the panel exciter, silent) on `store`.
  static api::ServerOptions in_process_options(const std::filesystem::path& store) {
    api::ServerOptions options;
    options.port = 0;
    options.store = store;
    options.engine.plant = models::plant_preset("panel-exciter");
    options.engine.chain.fs = options.engine.plant.fs;
    options.log = [](const std::string&) {};
    return options;
  }

 private:
  bool zombie() const {
    std::ifstream stat("/proc/" + std::to_string(pid_) + "/stat");
    std::string pid, name, state;
    stat >> pid >> name >> state;
    return state == "Z";
  }

  pid_t pid_ = -1;
};

TEST_F(CliServe, APortAnotherServerHoldsIsAnErrorNamingTheAddress) {
  api::Server first(in_process_options(dir_ / "first"));
  const int port = first.start();

  const RunResult r = run("serve --port " + std::to_string(port) + " --no-demo --web '' --store " +
                          quoted(dir_ / "second") + " --seconds 5");
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("panelbass: error: serve: cannot listen on http://127.0.0.1:" + std::to_string(port) + "/"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("in use"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("serving"), std::string::npos) << r.out;
  // The first server still answers alone.
  httplib::Client client("127.0.0.1", port);
  const httplib::Result health = client.Get("/api/health");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
}

TEST_F(CliServe, AStoreAnotherServerHoldsIsAnErrorNamingTheStoreAndItsProcess) {
  api::Server first(in_process_options(dir_ / "store"));
  first.start();

  // Another port, the same store: two servers would number their jobs alike and overwrite each other's.
  const RunResult r = run("serve --port 0 --no-demo --web '' --store " + quoted(dir_ / "store") + " --seconds 5");
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("panelbass: error: store " + (dir_ / "store").string() + " is in use by another panelbass serve (pid " +
                       std::to_string(::getpid()) + ")"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.out.find("serving"), std::string::npos) << r.out;
}

TEST_F(CliServe, TheDemosControllerIsDesignedForTheProgramItPlays) {
  start_serve("--port 0 --web '' --store " + quoted(dir_ / "store") + " --seconds 300");
  const int port = serve_port();
  ASSERT_GT(port, 0) << serve_err();
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(30, 0);
  const auto status = [&client] {
    const httplib::Result r = client.Get("/api/status");
    return r ? nlohmann::json::parse(r->body, nullptr, false) : nlohmann::json();
  };
  // The demo identifies, designs and activates (well under a minute on one core).
  std::string controller;
  for (int k = 0; k < 1800 && controller.empty(); ++k) {
    const nlohmann::json s = status();
    if (s.is_object() && s["active_models"]["feedforward"].is_string()) controller = s["active_models"]["feedforward"];
    if (controller.empty()) std::this_thread::sleep_for(100ms);
  }
  ASSERT_FALSE(controller.empty()) << serve_err();

  // Designed for a safe amplitude of the program's peak (serve's default --amplitude 0.2 of noise).
  const httplib::Result stored = client.Get(("/api/models/" + controller).c_str());
  ASSERT_TRUE(stored);
  const nlohmann::json model = nlohmann::json::parse(stored->body)["model"];
  EXPECT_EQ(model["kind"], "lq_feedforward");
  EXPECT_EQ(model["meta"]["R_search"]["target_noise_amplitude"], 0.2) << model["meta"];
  EXPECT_GE(model["meta"]["max_input"]["noise"].get<double>(), 0.2) << model["meta"];

  // Played, the program asks the limiter for (almost) nothing: a second after the swap, the last second's
  // share of samples asking for full scale or more is at most 1 in 1000 (the design's safe amplitude is
  // measured on another noise record than the one the engine loops).
  nlohmann::json after;
  for (int k = 0; k < 100; ++k) {
    after = status();
    if (after.is_object() && after["metrics"]["limiter_window_s"].get<double>() >= 0.9 && k >= 15) break;
    std::this_thread::sleep_for(100ms);
  }
  ASSERT_TRUE(after.is_object());
  EXPECT_LE(after["metrics"]["over_range_fraction"].get<double>(), 1e-3) << after;
  EXPECT_LE(after["metrics"]["limited_fraction"].get<double>(), 0.05) << after;
  EXPECT_LT(after["metrics"]["peak_drive"].get<double>(), 0.999) << after;
}

}  // namespace
}  // namespace panelbass

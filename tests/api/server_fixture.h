#pragma once
// The real server on a loopback port for the API's tests: a fixture that starts it (virtual transducer,
// panel-exciter preset, a looped noise program of peak 0.2), requests through cpp-httplib's client or as raw
// bytes (what curl sends and the client never would), and small controllers to activate.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "api/server.h"
#include "models/control/lq_feedforward.h"
#include "models/control/neural_feedback.h"
#include "models/plant/plant_presets.h"
#include "tests/api/raw_http.h"
#include "tests/engine/engine_test_models.h"
#include "tests/support/controllers.h"
#include "tests/support/scratch_directory.h"

// After the project's (Eigen) headers: glibc's resolv.h, which httplib pulls in, defines a macro `_res`.
#include <httplib.h>

namespace panelbass::api::api_testing {

using namespace std::chrono_literals;

/// A response: status and the body parsed as JSON (null when it is not JSON).
struct Reply {
  int status = 0;        ///< HTTP status (-1: no response)
  nlohmann::json body;   ///< the body as JSON, or null
  std::string text;      ///< the body as sent
};

/// The Reply of a cpp-httplib result.
inline Reply reply_of(const httplib::Result& r) {
  if (!r) return {-1, nullptr, "transport error " + httplib::to_string(r.error())};
  Reply out{r->status, nullptr, r->body};
  out.body = nlohmann::json::parse(r->body, nullptr, false);
  if (out.body.is_discarded()) out.body = nullptr;
  return out;
}

/// The message of an error reply ("" when it is not one).
inline std::string error_message(const Reply& r) {
  return r.body.is_object() && r.body.contains("error") ? r.body["error"].value("message", "") : "";
}

/// Sends `request` (the raw bytes of one HTTP request, "Connection: close" in it) to 127.0.0.1:`port` without
/// ending the sending side (as curl does), reads the response until the server closes the connection (at most
/// 30 s) and returns its status and body.
inline Reply raw_request(int port, const std::string& request) {
  const RawReply r = send_raw(port, request);
  if (r.status < 0) return {-1, nullptr, "no response: " + r.text};
  return {r.status, r.body, r.text};
}

/// A job's work that runs until `release` is set (reporting progress, so that it can be cancelled): it keeps a
/// worker busy for as long as a test needs.
inline JobWork job_held_until(const std::atomic<bool>& release) {
  return [&release](const nlohmann::json&, JobControl& control) {
    while (!release.load()) {
      control.progress(0.0, "held");
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return nlohmann::json::object();
  };
}

/// An LQ feedforward controller whose drive is u*(k) = u(k) + c·u(k−1) (gain between |1 − |c|| and 1 + |c|):
/// one state, A = −c, B = 1, L = −c, so that A − B·L = 0 (u*/u = 1 + c·z⁻¹ by [7B]).
inline nlohmann::json lq_gain_controller(double c) { return testing_support::fir_gain_controller(c, engine::testing::kFs); }

/// A neural feedback controller with N1's weights zero (its drive is the soft-limited feedforward output) on
/// engine::testing::example_narx(`plant_seed`).
inline nlohmann::json zero_feedback_controller(std::uint64_t plant_seed) {
  models::FeedbackStructure s;
  s.nu = 1;
  s.nv = 1;
  s.ny = 2;
  s.hidden = {3};
  return models::neural_feedback_to_json(
      models::NeuralFeedback::with_structure(s, engine::testing::example_narx(plant_seed)));
}

/// The server in a scratch folder, with a client.
class ServerTest : public testing_support::ScratchDirectoryTest {
 protected:
  /// Options of a server on any free port with its store at `store`, playing uniform noise of peak 0.2.
  ServerOptions options(const std::filesystem::path& store) {
    ServerOptions o;
    o.port = 0;
    o.store = store;
    o.engine.plant = models::plant_preset("panel-exciter");
    o.engine.chain.fs = o.engine.plant.fs;
    const Eigen::VectorXd program = engine::testing::uniform(3000, 0.2, 7);
    o.engine.program.assign(program.data(), program.data() + program.size());
    o.log = [this](const std::string& line) {
      const std::lock_guard lock(log_mutex_);
      log_.push_back(line);
    };
    return o;
  }

  /// Starts a server with `o` and a client for it.
  void start(ServerOptions o) {
    // A restart: the old server lets go of its store (one server per store) before the new one opens it.
    client_.reset();
    server_.reset();
    server_ = std::make_unique<Server>(std::move(o));
    port_ = server_->start();
    client_ = std::make_unique<httplib::Client>("127.0.0.1", port_);
    client_->set_read_timeout(30, 0);
  }
  /// Starts a server with options(dir_ / "store").
  void start() { start(options(dir_ / "store")); }

  /// GET `path`.
  Reply get(const std::string& path) { return reply_of(client_->Get(path.c_str())); }
  /// POST `body` as application/json.
  Reply post(const std::string& path, const std::string& body) {
    return reply_of(client_->Post(path.c_str(), body, "application/json"));
  }
  /// POST `body` as application/json.
  Reply post(const std::string& path, const nlohmann::json& body) { return post(path, body.dump()); }
  /// PUT `body` as application/json.
  Reply put(const std::string& path, const nlohmann::json& body) {
    return reply_of(client_->Put(path.c_str(), body.dump(), "application/json"));
  }
  /// PATCH `body` as application/json.
  Reply patch(const std::string& path, const std::string& body) {
    return reply_of(client_->Patch(path.c_str(), body, "application/json"));
  }
  /// DELETE `path`.
  Reply del(const std::string& path) { return reply_of(client_->Delete(path.c_str())); }

  /// Waits until job `id` has ended (at most `timeout`) and returns its record.
  nlohmann::json wait_job(const std::string& id, std::chrono::seconds timeout = 120s) {
    const auto until = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      const Reply r = get("/api/jobs/" + id);
      const std::string state = r.body.value("state", "");
      if (state == "succeeded" || state == "failed" || state == "cancelled") return r.body;
      if (std::chrono::steady_clock::now() > until) return r.body;
      std::this_thread::sleep_for(50ms);
    }
  }

  /// Polls GET /api/status until `condition` holds (at most 20 s); returns the last status.
  nlohmann::json wait_status(const std::function<bool(const nlohmann::json&)>& condition) {
    const auto until = std::chrono::steady_clock::now() + 20s;
    nlohmann::json status;
    do {
      status = get("/api/status").body;
      if (condition(status)) return status;
      std::this_thread::sleep_for(20ms);
    } while (std::chrono::steady_clock::now() < until);
    return status;
  }

  /// Uploads `model` (expecting 201 or 200) and returns its id.
  std::string upload(const nlohmann::json& model) {
    const Reply r = post("/api/models", model);
    EXPECT_TRUE(r.status == 201 || r.status == 200) << r.text;
    return r.body.value("id", "");
  }

  /// The log lines the server wrote so far.
  std::vector<std::string> log_lines() {
    const std::lock_guard lock(log_mutex_);
    return log_;
  }

  std::unique_ptr<Server> server_;
  int port_ = 0;
  std::unique_ptr<httplib::Client> client_;
  std::mutex log_mutex_;
  std::vector<std::string> log_;
};

}  // namespace panelbass::api::api_testing

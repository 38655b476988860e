#pragma once
// `panelbass serve` in one object: the engine on the virtual transducer, the model store, the job
// queue, and the HTTP API (cpp-httplib) with the web UI, as described in api/ROUTES.md.

#include <atomic>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "api/engine_service.h"
#include "api/jobs/job_kinds.h"
#include "api/job_queue.h"
#include "api/model_store.h"
#include "api/record_store.h"

namespace httplib {
class Server;
}

namespace panelbass::api {

/// One route of the API: method and path template as the OpenAPI document writes it ("/api/models/{id}").
struct Route {
  std::string method;  ///< "get", "post", "put", "patch", "delete"
  std::string path;    ///< path template
};

/// Every route the server answers (besides the web UI's static files).
const std::vector<Route>& api_routes();

/// The OpenAPI 3 document of the API (api/openapi.json, compiled in).
const nlohmann::json& openapi_document();

/// How the server runs.
struct ServerOptions {
  std::string bind = "127.0.0.1";          ///< address to listen on
  int port = 8080;                         ///< 0 = any free port
  std::string token;                       ///< required (Bearer) for every /api and /metrics request if set; required to bind beyond loopback
  std::size_t body_limit = 16u << 20;      ///< largest request body, bytes
  std::filesystem::path store = "panelbass-store";  ///< the store folder
  std::filesystem::path web_root;          ///< the web UI folder served at / (empty: no UI)
  int workers = 1;                         ///< job worker threads
  int http_threads = 16;                   ///< HTTP worker threads (each open event stream holds one)
  EngineServiceOptions engine;             ///< what the engine plays
  /// Where start-up warnings (skipped store files) and notices go.
  std::function<void(const std::string&)> log;
};

/// The running service.
class Server {
 public:
  /// Opens the store (skipping bad files with a warning), restores finished jobs, builds the engine.
  /// Throws std::invalid_argument for bad options (a non-loopback address without a token, …) and
  /// StoreError if the store folder is unusable.
  explicit Server(ServerOptions options);
  /// Stops everything.
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// Binds, starts the engine and serves on a background thread; returns the port. Throws
  /// std::runtime_error if the address cannot be bound.
  int start();
  /// Stops the HTTP server, the job queue and the engine (idempotent).
  void stop();
  /// Blocks until stop() is called from elsewhere (or a signal handler asks for it via request_stop()).
  void wait();
  /// Asks wait() to return; safe from a signal handler.
  void request_stop() { stop_requested_.store(true, std::memory_order_relaxed); }

  /// Submits a job as POST /api/jobs does (params validated; throws std::invalid_argument); returns its id.
  std::string submit_job(const std::string& kind, const nlohmann::json& params, bool activate);
  /// The job queue (tests and the start-up demo wait on it).
  JobQueue& jobs() { return *jobs_; }
  /// The store.
  ModelStore& store() { return *store_; }
  /// The engine.
  EngineService& engine() { return *engine_; }
  /// "http://127.0.0.1:PORT/" once started.
  std::string address() const;

 private:
  // The server's settings, then every route group (api/routes/: a file per group).
  void register_routes();
  void register_service_routes();  // health, status, openapi, metrics
  void register_config_routes();   // /api/config
  void register_model_routes();    // /api/models…
  void register_record_routes();   // /api/records…
  void register_job_routes();      // /api/jobs…
  void on_job_finished(JobRecord& job);
  nlohmann::json status_json() const;
  std::string metrics_text() const;
  void count_response(int status);

  ServerOptions options_;
  std::unique_ptr<ModelStore> store_;
  std::unique_ptr<RecordStore> records_;  // uploaded recordings, beside the models
  std::unique_ptr<EngineService> engine_;
  JobEnvironment environment_;
  std::map<std::string, bool> activate_on_success_;  // job id → activate its model when it succeeds
  std::mutex activate_mutex_;
  std::unique_ptr<JobQueue> jobs_;
  std::unique_ptr<httplib::Server> http_;
  std::thread http_thread_;
  std::thread housekeeping_;
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> running_{false};
  int port_ = 0;
  mutable std::mutex counts_mutex_;
  std::map<int, std::uint64_t> responses_;  // by status code
};

}  // namespace panelbass::api

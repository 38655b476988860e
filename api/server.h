#pragma once
// `panelbass serve` in one object: the engine on the virtual transducer, the model store, the job
// queue, and the HTTP API (cpp-httplib) with the web UI, as described in api/ROUTES.md.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "api/engine_service.h"
#include "api/http/request_guard.h"
#include "api/jobs/job_kinds.h"
#include "api/job_queue.h"
#include "api/model_store.h"
#include "api/record_store.h"
#include "api/store_lock.h"

namespace panelbass::api {

class GuardedHttpServer;

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
  std::vector<std::string> allowed_origins;  ///< origins besides the server's own that may change state (serve --allow-origin)
  std::vector<std::string> allowed_hosts;    ///< Host names besides the bound address and localhost (serve --allow-host)
  std::size_t body_limit = 16u << 20;      ///< largest request body, bytes (every byte after the head, chunked framing included)
  std::filesystem::path store = "panelbass-store";  ///< the store folder
  std::filesystem::path web_root;          ///< the web UI folder served at / (empty: no UI)
  int workers = 1;                         ///< job worker threads
  int http_threads = 64;                   ///< connections served at once, a thread each (more are answered 503)
  std::chrono::milliseconds head_timeout{10000};  ///< a request's line and headers must arrive within this
  std::chrono::milliseconds body_timeout{60000};  ///< and its body within this after them
  int event_streams = 16;                  ///< job event streams open at once (each holds a connection; more: 503)
  std::size_t max_queued_jobs = 32;        ///< jobs waiting for a worker (more: 429)
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
  std::string submit_job(const std::string& kind, const nlohmann::json& params, std::optional<bool> activate);
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
  void register_program_routes();  // /api/program
  void register_model_routes();    // /api/models…
  void register_record_routes();   // /api/records…
  void register_job_routes();      // /api/jobs…
  void on_job_finished(JobRecord& job);
  nlohmann::json status_json() const;
  std::string metrics_text() const;
  void count_response(int status);
  // The checks before any route (Host, Origin, content type, declared length, token); true if it answered.
  bool refuse_before_routing(const httplib::Request& req, httplib::Response& res);

  ServerOptions options_;
  std::unique_ptr<StoreLock> store_lock_;  // one server per store, taken before anything in it is read
  std::unique_ptr<ModelStore> store_;
  std::unique_ptr<RecordStore> records_;  // uploaded recordings, beside the models
  std::unique_ptr<EngineService> engine_;
  JobEnvironment environment_;
  std::map<std::string, bool> activate_on_success_;  // job id → activate its model when it succeeds
  std::mutex activate_mutex_;
  std::unique_ptr<JobQueue> jobs_;
  std::unique_ptr<GuardedHttpServer> http_;
  OriginPolicy origin_policy_;
  std::atomic<int> open_event_streams_{0};
  std::atomic<std::uintmax_t> store_bytes_{0};  // the store folder's size, measured by the housekeeping thread
  std::thread http_thread_;
  std::thread housekeeping_;
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> running_{false};
  int port_ = 0;
  mutable std::mutex counts_mutex_;
  std::map<int, std::uint64_t> responses_;  // by status code
};

}  // namespace panelbass::api

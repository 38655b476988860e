#include "api/server.h"

#include <httplib.h>
#include <malloc.h>
#include <sys/socket.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "api/http/guarded_http_server.h"
#include "api/request_body.h"
#include "api/routes/route_helpers.h"
#include "models/kinds/model_file.h"

namespace panelbass::api {
namespace {

const std::vector<Route> kRoutes = {
    {"get", "/api/health"},          {"get", "/api/status"},
    {"get", "/api/config"},          {"put", "/api/config"},
    {"patch", "/api/config"},        {"get", "/api/models"},
    {"post", "/api/models"},         {"get", "/api/models/{id}"},
    {"delete", "/api/models/{id}"},  {"post", "/api/models/{id}/activate"},
    {"get", "/api/jobs"},            {"post", "/api/jobs"},
    {"get", "/api/jobs/{id}"},       {"delete", "/api/jobs/{id}"},
    {"get", "/api/jobs/{id}/events"}, {"get", "/api/openapi.json"},
    {"get", "/metrics"},
    {"get", "/api/records"},         {"post", "/api/records"},
    {"get", "/api/records/{id}"},    {"delete", "/api/records/{id}"},
    {"get", "/api/program"},         {"put", "/api/program"},
};

// The bytes of every file under `folder` (what the store takes on disk); 0 for what cannot be read.
std::uintmax_t folder_size(const std::filesystem::path& folder) {
  std::uintmax_t bytes = 0;
  std::error_code error;
  for (std::filesystem::recursive_directory_iterator it(folder, error), end; !error && it != end; it.increment(error)) {
    std::error_code ignored;
    if (!it->is_regular_file(ignored)) continue;
    const std::uintmax_t size = it->file_size(ignored);
    if (!ignored) bytes += size;
  }
  return bytes;
}

bool is_loopback(const std::string& address) {
  return address == "127.0.0.1" || address == "::1" || address == "localhost";
}

}  // namespace

const std::vector<Route>& api_routes() { return kRoutes; }

Server::Server(ServerOptions options) : options_(std::move(options)) {
  if (!options_.log) options_.log = [](const std::string&) {};
  // Two malloc arenas for the process instead of glibc's 8 per core: with a pool of HTTP threads each
  // taking an arena of its own, freed memory scattered over many arenas kept the resident size growing
  // for as long as the server ran (bench/soak.py: 33 → 105 MB in 10 min, while heaptrack saw a peak heap
  // of 18 MB and 71 KB left at exit; with two arenas 19 → 33 MB in 6 min).
  // Set before any of the server's threads exists.
  mallopt(M_ARENA_MAX, 2);
  if (!is_loopback(options_.bind) && options_.token.empty()) {
    throw std::invalid_argument("--bind " + options_.bind +
                                ": binding beyond the loopback address requires --token (clients then send "
                                "Authorization: Bearer <token>)");
  }
  if (options_.workers < 1) throw std::invalid_argument("--workers: must be at least 1");
  origin_policy_.bind = options_.bind;
  for (const std::string& origin : options_.allowed_origins) {
    origin_policy_.allowed_origins.push_back(normalized_origin(origin));
  }
  origin_policy_.allowed_hosts = options_.allowed_hosts;
  store_lock_ = std::make_unique<StoreLock>(options_.store);
  store_ = std::make_unique<ModelStore>(options_.store, [this](const std::string& w) { options_.log("warning: " + w); });
  records_ = std::make_unique<RecordStore>(options_.store, [this](const std::string& w) { options_.log("warning: " + w); });
  engine_ = std::make_unique<EngineService>(options_.engine);

  environment_.fs = engine_->fs();
  // On a sound card the jobs measure through it; there is no simulated transducer to compare with.
  environment_.excite = [this](const Eigen::VectorXd& drive) { return engine_->excite(drive); };
  environment_.safe_level = engine_->safe_level();
  environment_.chain = [this] { return engine_->running_chain(); };
  if (engine_->device_status()) {
    environment_.measure = [this](const Eigen::VectorXd& drive) { return engine_->measure(drive); };
  } else {
    environment_.plant = engine_->plant();
  }
  environment_.store = store_.get();
  environment_.records = records_.get();
  environment_.job_result = [this](const std::string& id) -> std::optional<nlohmann::json> {
    const std::optional<JobRecord> job = jobs_->get(id);
    if (!job || job->state != JobState::succeeded) return std::nullopt;
    if (job->result_dropped) {
      const std::optional<nlohmann::json> stored = store_->job(id);
      if (!stored || !stored->contains("result")) return std::nullopt;
      return (*stored)["result"];
    }
    return job->result;
  };
  jobs_ = std::make_unique<JobQueue>(options_.workers, [this](JobRecord& job) { on_job_finished(job); });
  jobs_->set_max_waiting(options_.max_queued_jobs);
  for (const nlohmann::json& record : store_->jobs()) {
    try {
      jobs_->restore(job_from_json(record));
    } catch (const std::exception& e) {
      options_.log(std::string("warning: a stored job record was skipped: ") + e.what());
    }
  }
  store_->release_jobs();
  HttpLimits limits;
  limits.body_bytes = options_.body_limit;
  limits.max_connections = static_cast<std::size_t>(std::max(options_.http_threads, 2));
  limits.head_timeout = options_.head_timeout;
  limits.body_timeout = options_.body_timeout;
  http_ = std::make_unique<GuardedHttpServer>(limits);
  register_routes();
}

Server::~Server() { stop(); }

std::string Server::address() const {
  const std::string host = options_.bind.find(':') != std::string::npos ? "[" + options_.bind + "]" : options_.bind;
  return "http://" + host + ":" + std::to_string(port_) + "/";
}

void Server::count_response(int status) {
  const std::lock_guard lock(counts_mutex_);
  ++responses_[status];
}

void Server::on_job_finished(JobRecord& job) {
  bool activate = false;
  {
    const std::lock_guard lock(activate_mutex_);
    const auto it = activate_on_success_.find(job.id);
    if (it != activate_on_success_.end()) {
      activate = it->second;
      activate_on_success_.erase(it);
    }
  }
  if (activate && job.state == JobState::succeeded && job.result.contains("model_id") && job.result["model_id"].is_string()) {
    const std::string id = job.result["model_id"].get<std::string>();
    try {
      const std::optional<StoredModel> entry = store_->find(id);
      const std::optional<nlohmann::json> model = store_->model(id);
      if (!entry || !model) throw std::runtime_error("model " + id + " is not in the store");
      const ModelSlotName slot = slot_for(id, entry->kind);
      engine_->activate(slot, id, *model);
      job.extra["activated"] = {{"slot", slot_name(slot)}, {"id", id}};
    } catch (const std::exception& e) {
      job.extra["activation_error"] = e.what();
    }
  }
  try {
    store_->put_job(job.id, job_to_json(job, true));
  } catch (const std::exception& e) {
    options_.log(std::string("warning: job ") + job.id + " could not be stored: " + e.what());
  }
}

std::string Server::submit_job(const std::string& kind, const nlohmann::json& params, std::optional<bool> activate_asked) {
  const bool activate = activate_asked.value_or(activates_by_default(kind));
  if (activate) {
    const std::string made = model_kind_made_by(kind);
    if (made.empty() && std::find(job_kinds().begin(), job_kinds().end(), kind) != job_kinds().end()) {
      throw std::invalid_argument("activate: the job kind " + kind + " makes no model to activate");
    }
    if (!made.empty() && slots_accepting(made).empty()) {
      const auto role = [](models::ModelRole r) { return models::model_kind_names(static_cast<unsigned>(r)); };
      throw std::invalid_argument("activate: the job kind " + kind + " makes a " + made +
                                  " plant model, which no slot runs (the feedforward slot takes " +
                                  role(models::ModelRole::feedforward) + ", the feedback slot " +
                                  role(models::ModelRole::feedback) + ")");
    }
  }
  const nlohmann::json checked = validate_job_params(kind, params, environment_);
  // The queued record is on disk before a worker can start the job (a restart shows it as interrupted).
  // So is the wish to activate its result, which a fast job could otherwise finish before.
  return jobs_->submit(kind, checked, job_work(kind, environment_), [this, activate](const JobRecord& queued) {
    store_->put_job(queued.id, job_to_json(queued, true));
    if (activate) {
      const std::lock_guard lock(activate_mutex_);
      activate_on_success_[queued.id] = true;
    }
  });
}

bool Server::refuse_before_routing(const httplib::Request& req, httplib::Response& res) {
  // A request answered here leaves its body unread: the connection cannot carry another request after it.
  const auto close_after = [&req] {
    if (req.has_header("Content-Length") || req.has_header("Transfer-Encoding")) {
      const_cast<httplib::Request&>(req).set_header("Connection", "close");
    }
  };
  const auto refuse = [&res, &close_after](const HttpError& e) {
    close_after();
    send_error(res, e.status, e.code, e.message);
    return true;
  };
  const std::optional<HttpError> early = refusal(req, origin_policy_, options_.body_limit);
  if (early && early->status == 421) return refuse(*early);  // a foreign Host learns nothing more
  if (req.method == "OPTIONS") {
    if (const std::optional<HttpError> foreign = answer_options(req, res, origin_policy_)) return refuse(*foreign);
    close_after();
    return true;
  }
  if (!options_.token.empty()) {
    const bool guarded_path = req.path.rfind("/api", 0) == 0 || req.path.rfind("/metrics", 0) == 0;
    if (guarded_path && req.get_header_value("Authorization") != "Bearer " + options_.token) {
      return refuse(HttpError{401, "unauthorized", "this server requires Authorization: Bearer <token>"});
    }
  }
  if (early) return refuse(*early);
  return false;
}

void Server::register_routes() {
  GuardedHttpServer& http = *http_;
  // Without it, small responses on a kept-alive connection wait for the client's delayed ACK (~40 ms).
  http.set_tcp_nodelay(true);
  // The library's default adds SO_REUSEPORT, with which a second server binds the same port and the two
  // answer one address in turn; SO_REUSEADDR alone still allows a restart while old connections linger.
  http.set_socket_options([](socket_t sock) {
    const int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  for (const auto& [ext, mime] : std::initializer_list<std::pair<const char*, const char*>>{
           {"js", "text/javascript"}, {"mjs", "text/javascript"}, {"css", "text/css"}, {"html", "text/html"},
           {"json", "application/json"}, {"svg", "image/svg+xml"}, {"png", "image/png"}}) {
    http.set_file_extension_and_mimetype_mapping(ext, mime);
  }
  if (!options_.web_root.empty()) {
    if (!http.set_mount_point("/", options_.web_root.string())) {
      throw std::invalid_argument("--web " + options_.web_root.string() + ": not a folder");
    }
  }
  // Every check runs before the body is read: curl's Expect: 100-continue gets its refusal instead of a go-ahead.
  http.set_expect_100_continue_handler([this](const httplib::Request& req, httplib::Response& res) {
    return refuse_before_routing(req, res) ? res.status : 100;
  });
  http.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    if (refuse_before_routing(req, res)) return httplib::Server::HandlerResponse::Handled;
    add_cors_headers(req, res, origin_policy_);
    accept_any_body(req);
    return httplib::Server::HandlerResponse::Unhandled;
  });
  http.set_error_handler([limit = options_.body_limit](const httplib::Request& req, httplib::Response& res) {
    // A body cut off at the limit or a deadline reads as a malformed request to the library: say which it was.
    const ReadFailure failure = GuardedHttpServer::current_read_failure();
    if (failure != ReadFailure::none) {
      const_cast<httplib::Request&>(req).set_header("Connection", "close");
      res.body.clear();
      res.status = read_failure_status(failure);
      send_error(res, res.status, code_of_status(res.status), read_failure_message(failure, limit));
      return;
    }
    if (!res.body.empty()) return;
    send_error(res, res.status, code_of_status(res.status), library_error_message(req, res.status, limit));
  });
  http.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr error) {
    std::string message = "unknown error";
    try {
      std::rethrow_exception(error);
    } catch (const std::exception& e) {
      message = e.what();
    } catch (...) {
    }
    send_error(res, 500, "internal", message);
  });
  http.set_logger([this](const httplib::Request&, const httplib::Response& res) { count_response(res.status); });

  register_service_routes();
  register_config_routes();
  register_program_routes();
  register_model_routes();
  register_record_routes();
  register_job_routes();
}

int Server::start() {
  if (running_.exchange(true)) throw std::runtime_error("serve: already started");
  const int port = options_.port == 0 ? http_->bind_to_any_port(options_.bind)
                                      : (http_->bind_to_port(options_.bind, options_.port) ? options_.port : -1);
  port_ = port < 0 ? options_.port : port;
  if (port < 0) {
    running_ = false;
    throw std::runtime_error("serve: cannot listen on " + address() + ": the port is in use (another panelbass "
                             "serve?) or the address is not one of this machine's; choose another with --port or --bind");
  }
  engine_->start();
  http_thread_ = std::thread([this] { http_->listen_after_bind(); });
  housekeeping_ = std::thread([this] {
    for (std::uint64_t tick = 1; running_.load(std::memory_order_relaxed); ++tick) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      engine_->housekeeping();
      if (tick % 20 == 1) store_bytes_.store(folder_size(options_.store));
      // Every 10 s, hand freed memory back to the system: each HTTP thread's malloc arena otherwise keeps
      // its largest response's worth (a list of thousands of models) for the life of the process.
      if (tick % 100 == 0) malloc_trim(0);
    }
  });
  return port_;
}

void Server::wait() {
  while (running_.load(std::memory_order_relaxed) && !stop_requested_.load(std::memory_order_relaxed)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

void Server::stop() {
  if (!running_.exchange(false)) {
    jobs_.reset();
    return;
  }
  http_->stop();
  if (http_thread_.joinable()) http_thread_.join();
  if (housekeeping_.joinable()) housekeeping_.join();
  jobs_.reset();  // cancels and joins the workers (their records are stored by on_job_finished)
  engine_->stop();
}

}  // namespace panelbass::api

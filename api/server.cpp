#include "api/server.h"

#include <httplib.h>
#include <malloc.h>

#include <sys/socket.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <system_error>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "api/model_validation.h"
#include "api/prometheus.h"
#include "api/request_body.h"
#include "dsp/sample_rate.h"
#include "api/metrics_json.h"
#include "models/io/json_fields.h"
#include "models/io/number_text.h"

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
};

const char* kJsonType = "application/json";

void send_json(httplib::Response& res, int status, const nlohmann::json& body) {
  res.status = status;
  // Error messages may quote what a client sent, invalid UTF-8 included: replace it rather than throw.
  res.set_content(body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace), kJsonType);
}

void send_error(httplib::Response& res, int status, const std::string& code, const std::string& message) {
  send_json(res, status, {{"error", {{"code", code}, {"message", message}}}});
}

const char* code_of_status(int status) {
  switch (status) {
    case 400: return "bad_request";
    case 401: return "unauthorized";
    case 404: return "not_found";
    case 405: return "method_not_allowed";
    case 409: return "conflict";
    case 413: return "too_large";
    case 415: return "unsupported_media_type";
    case 422: return "invalid_model";
    case 503: return "unavailable";
    case 507: return "storage";
    default: return status >= 500 ? "internal" : "bad_request";
  }
}

// Rejects fields of `object` not in `allowed`, naming the first (`where` is its key path).
void reject_unknown_fields(const nlohmann::json& object, std::initializer_list<const char*> allowed,
                           const std::string& where) {
  if (!object.is_object()) throw HttpError{400, "bad_request", where + ": expected a JSON object"};
  for (const auto& [key, value] : object.items()) {
    bool known = false;
    for (const char* name : allowed) known = known || key == name;
    if (!known) throw HttpError{400, "bad_request", (where.empty() ? "" : where + ".") + key + ": unknown field"};
  }
}

std::string path_id(const httplib::Request& req, const char* what) {
  const std::string id = req.matches[1];
  if (!is_valid_id(id)) {
    throw HttpError{400, "bad_request", std::string(what) + " id \"" + id +
                                             "\": ids are 1 to 64 letters, digits, '-' or '_'"};
  }
  return id;
}

// A list's page size unless the client names one, and the largest it may name.
constexpr std::size_t kDefaultPageLimit = 100;
constexpr std::size_t kMaxPageLimit = 1000;

// The query's non-negative integer `key` (at most `most`), or `fallback` when absent; 400 naming it otherwise.
std::size_t query_count(const httplib::Request& req, const char* key, std::size_t fallback, std::size_t most) {
  if (!req.has_param(key)) return fallback;
  const std::string text = req.get_param_value(key);
  std::size_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size()) {
    throw HttpError{400, "bad_request", std::string(key) + ": expected an integer >= 0, got \"" + text + "\""};
  }
  return std::min(value, most);
}

bool is_loopback(const std::string& address) {
  return address == "127.0.0.1" || address == "::1" || address == "localhost";
}

// Runs a route handler, turning every exception into the API's error object.
httplib::Server::Handler guarded(std::function<void(const httplib::Request&, httplib::Response&)> handler) {
  return [handler = std::move(handler)](const httplib::Request& req, httplib::Response& res) {
    try {
      handler(req, res);
    } catch (const HttpError& e) {
      send_error(res, e.status, e.code, e.message);
    } catch (const EngineRequestError& e) {
      send_error(res, e.status(), e.code(), e.what());
    } catch (const ModelRejected& e) {
      send_error(res, e.code() == "invalid_model" ? 422 : 400, e.code(), e.what());
    } catch (const StoreError& e) {
      send_error(res, 507, "storage", e.what());
    } catch (const std::invalid_argument& e) {
      send_error(res, 400, "bad_request", e.what());
    } catch (const std::exception& e) {
      send_error(res, 500, "internal", e.what());
    }
  };
}

// The kind of model a job of `job_kind` makes ("" if it makes none).
std::string model_kind_made_by(const std::string& job_kind) {
  if (job_kind == "identify-linear") return "linear";
  if (job_kind == "identify-narx") return "narx";
  if (job_kind == "design-lq") return "lq_feedforward";
  if (job_kind == "design-nn") return "neural_feedback";
  return "";
}

// The slot model `id` of `kind` goes to when a client names none; EngineRequestError (409) if none runs it.
ModelSlotName slot_for(const std::string& id, const std::string& kind) {
  if (const std::optional<ModelSlotName> slot = default_slot(kind)) return *slot;
  require_slot_accepts(ModelSlotName::feedforward, id, kind);  // throws, naming the kind and what slots take
  return ModelSlotName::feedforward;
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
  store_ = std::make_unique<ModelStore>(options_.store, [this](const std::string& w) { options_.log("warning: " + w); });
  records_ = std::make_unique<RecordStore>(options_.store, [this](const std::string& w) { options_.log("warning: " + w); });
  engine_ = std::make_unique<EngineService>(options_.engine);

  environment_.fs = engine_->fs();
  // On a sound card the jobs measure through it; there is no simulated transducer to compare with.
  environment_.excite = [this](const Eigen::VectorXd& drive) { return engine_->excite(drive); };
  environment_.safe_level = engine_->safe_level();
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
  for (const nlohmann::json& record : store_->jobs()) {
    try {
      jobs_->restore(job_from_json(record));
    } catch (const std::exception& e) {
      options_.log(std::string("warning: a stored job record was skipped: ") + e.what());
    }
  }
  store_->release_jobs();
  http_ = std::make_unique<httplib::Server>();
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
  if (activate && job.state == JobState::succeeded && job.result.contains("model_id")) {
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

std::string Server::submit_job(const std::string& kind, const nlohmann::json& params, bool activate) {
  if (activate) {
    const std::string made = model_kind_made_by(kind);
    if (made.empty() && std::find(job_kinds().begin(), job_kinds().end(), kind) != job_kinds().end()) {
      throw std::invalid_argument("activate: the job kind " + kind + " makes no model to activate");
    }
    if (!made.empty() && slots_accepting(made).empty()) {
      throw std::invalid_argument("activate: the job kind " + kind + " makes a " + made +
                                  " plant model, which no slot runs (the feedforward slot takes an lq_feedforward "
                                  "controller from design-lq, the feedback slot a neural_feedback one from design-nn)");
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

nlohmann::json Server::status_json() const {
  nlohmann::json metrics = api::metrics_to_json(engine_->metrics());
  metrics.erase("active_ids");
  nlohmann::json active = nlohmann::json::object();
  for (const ModelSlotName slot : {ModelSlotName::feedforward, ModelSlotName::feedback}) {
    const std::optional<std::string> id = engine_->active_model(slot);
    active[slot_name(slot)] = id ? nlohmann::json(*id) : nlohmann::json(nullptr);
  }
  const LimiterActivity limiting = engine_->limiter_activity();
  metrics["limiter_window_s"] = limiting.window_s;
  metrics["limited_fraction"] = limiting.limited_fraction;
  metrics["over_range_fraction"] = limiting.over_range_fraction;
  metrics["needs_more_drive"] = limiting.needs_more_drive;
  return {{"engine", engine_->engine_status()},
          {"metrics", metrics},
          {"active_models", active},
          {"jobs", {{"queued", jobs_->count(JobState::queued)}, {"running", jobs_->count(JobState::running)}}}};
}

std::string Server::metrics_text() const {
  ServiceCounts counts;
  for (const JobState s : {JobState::queued, JobState::running, JobState::succeeded, JobState::failed,
                           JobState::cancelled}) {
    counts.jobs_by_state[job_state_name(s)] = jobs_->count(s);
  }
  {
    const std::lock_guard lock(counts_mutex_);
    counts.responses_by_status = responses_;
  }
  counts.models_stored = store_->list().size();
  counts.device = engine_->device_status();
  return prometheus_text(engine_->metrics(), counts);
}

void Server::register_routes() {
  httplib::Server& http = *http_;
  http.set_payload_max_length(options_.body_limit);
  // Without it, small responses on a kept-alive connection wait for the client's delayed ACK (~40 ms).
  http.set_tcp_nodelay(true);
  // The library's default adds SO_REUSEPORT, with which a second server binds the same port and the two
  // answer one address in turn; SO_REUSEADDR alone still allows a restart while old connections linger.
  http.set_socket_options([](socket_t sock) {
    const int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  http.new_task_queue = [threads = options_.http_threads] {
    return new httplib::ThreadPool(static_cast<std::size_t>(threads));
  };
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
  http.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    accept_any_body(req);
    if (options_.token.empty()) return httplib::Server::HandlerResponse::Unhandled;
    const bool guarded_path = req.path.rfind("/api", 0) == 0 || req.path.rfind("/metrics", 0) == 0;
    if (guarded_path && req.get_header_value("Authorization") != "Bearer " + options_.token) {
      send_error(res, 401, "unauthorized", "this server requires Authorization: Bearer <token>");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  http.set_error_handler([limit = options_.body_limit](const httplib::Request& req, httplib::Response& res) {
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

  const ModelLookup lookup = [this](const std::string& id) { return store_->model(id); };

  http.Get("/api/health", guarded([](const httplib::Request&, httplib::Response& res) {
             send_json(res, 200, {{"status", "ok"}, {"version", "0.1.0"}});
           }));
  http.Get("/api/status", guarded([this](const httplib::Request&, httplib::Response& res) {
             send_json(res, 200, status_json());
           }));
  http.Get("/api/openapi.json", guarded([](const httplib::Request&, httplib::Response& res) {
             send_json(res, 200, openapi_document());
           }));
  http.Get("/metrics", guarded([this](const httplib::Request&, httplib::Response& res) {
             res.set_content(metrics_text(), "text/plain; version=0.0.4");
           }));

  http.Get("/api/config", guarded([this](const httplib::Request&, httplib::Response& res) {
             send_json(res, 200, engine_->config());
           }));
  http.Put("/api/config", guarded([this, lookup](const httplib::Request& req, httplib::Response& res) {
             const nlohmann::json settings = parse_body(req, "the whole settings object, as GET /api/config returns it");
             const nlohmann::json change = engine_->put_config(settings, lookup);
             send_json(res, 200, {{"config", engine_->config()}, {"change", change}});
           }));
  http.Patch("/api/config", guarded([this, lookup](const httplib::Request& req, httplib::Response& res) {
               const nlohmann::json patch =
                   parse_body(req, "a JSON merge patch of the settings, e.g. {\"band_pass\":{\"low_hz\":30}}");
               const nlohmann::json change = engine_->patch_config(patch, lookup);
               send_json(res, 200, {{"config", engine_->config()}, {"change", change}});
             }));

  const auto model_summary = [this](const StoredModel& m) {
    nlohmann::json j = stored_model_to_json(m);
    nlohmann::json active_in = nlohmann::json::array();
    for (const ModelSlotName slot : {ModelSlotName::feedforward, ModelSlotName::feedback}) {
      if (engine_->active_model(slot) == m.id) active_in.push_back(slot_name(slot));
    }
    j["active_in"] = active_in;
    nlohmann::json slots = nlohmann::json::array();
    for (const ModelSlotName slot : slots_accepting(m.kind)) slots.push_back(slot_name(slot));
    j["slots"] = slots;
    return j;
  };
  http.Get("/api/models", guarded([this, model_summary](const httplib::Request&, httplib::Response& res) {
             nlohmann::json list = nlohmann::json::array();
             for (const StoredModel& m : store_->list()) list.push_back(model_summary(m));
             send_json(res, 200, {{"models", list}});
           }));
  http.Post("/api/models", guarded([this, model_summary](const httplib::Request& req, httplib::Response& res) {
              const nlohmann::json model = parse_body(
                  req, "a model file object ({\"format\":\"panelbass.model/1\",\"kind\":…})", nullptr, Overflow::invalid_model);
              if (!model.is_object()) throw HttpError{400, "bad_request", "body: expected a model file object"};
              const ValidatedModel valid = validate_model(model);
              if (!dsp::same_rate(valid.fs, engine_->fs())) {
                throw HttpError{422, "invalid_model",
                                "model.fs: the model runs at " + models::number_text(valid.fs) + " Hz, the engine at " +
                                    models::number_text(engine_->fs()) + " Hz"};
              }
              const std::string name = req.has_param("name") ? req.get_param_value("name") : "";
              bool created = false;
              const StoredModel stored = store_->put(model, valid.kind, valid.fs, name, "upload", &created);
              send_json(res, created ? 201 : 200, model_summary(stored));
            }));
  http.Get(R"(/api/models/([^/]+))", guarded([this, model_summary](const httplib::Request& req, httplib::Response& res) {
             const std::string id = path_id(req, "model");
             const std::optional<StoredModel> entry = store_->find(id);
             const std::optional<nlohmann::json> model = store_->model(id);
             if (!entry || !model) throw HttpError{404, "not_found", "no stored model \"" + id + "\""};
             nlohmann::json j = model_summary(*entry);
             j["model"] = *model;
             send_json(res, 200, j);
           }));
  http.Delete(R"(/api/models/([^/]+))", guarded([this](const httplib::Request& req, httplib::Response& res) {
                const std::string id = path_id(req, "model");
                if (!store_->find(id)) throw HttpError{404, "not_found", "no stored model \"" + id + "\""};
                for (const ModelSlotName slot : {ModelSlotName::feedforward, ModelSlotName::feedback}) {
                  if (engine_->active_model(slot) == id) {
                    throw HttpError{409, "conflict", "model \"" + id + "\" is active in the " + slot_name(slot) +
                                                         " slot; activate another model or clear the slot first"};
                  }
                }
                store_->remove(id);
                res.status = 204;
              }));
  http.Post(R"(/api/models/([^/]+)/activate)",
            guarded([this](const httplib::Request& req, httplib::Response& res) {
              const std::string id = path_id(req, "model");
              const nlohmann::json body = parse_body(req, "", nlohmann::json::object());
              reject_unknown_fields(body, {"slot"}, "body");
              const std::optional<StoredModel> entry = store_->find(id);
              const std::optional<nlohmann::json> model = store_->model(id);
              if (!entry || !model) throw HttpError{404, "not_found", "no stored model \"" + id + "\""};
              if (body.contains("slot") && !body["slot"].is_string()) {
                throw HttpError{400, "bad_request", "body.slot: expected \"feedforward\" or \"feedback\""};
              }
              const ModelSlotName slot =
                  body.contains("slot") ? parse_slot_name(body["slot"].get<std::string>()) : slot_for(id, entry->kind);
              const nlohmann::json change = engine_->activate(slot, id, *model);
              send_json(res, 200, {{"slot", slot_name(slot)}, {"id", id}, {"change", change}});
            }));

  register_record_routes();

  http.Get("/api/jobs", guarded([this](const httplib::Request&, httplib::Response& res) {
             nlohmann::json list = nlohmann::json::array();
             for (const JobRecord& job : jobs_->list()) list.push_back(job_to_json(job, false));
             send_json(res, 200, {{"jobs", list}});
           }));
  http.Post("/api/jobs", guarded([this](const httplib::Request& req, httplib::Response& res) {
              const nlohmann::json body =
                  parse_body(req, "{\"kind\":\"identify-linear\",\"params\":{…},\"activate\":false} (kind required)");
              reject_unknown_fields(body, {"kind", "params", "activate"}, "body");
              if (!body.contains("kind") || !body["kind"].is_string()) {
                throw HttpError{400, "bad_request", "body.kind: required, a string (e.g. \"identify-linear\")"};
              }
              const nlohmann::json params = body.value("params", nlohmann::json::object());
              if (!params.is_object()) throw HttpError{400, "bad_request", "body.params: expected a JSON object"};
              if (body.contains("activate") && !body["activate"].is_boolean()) {
                throw HttpError{400, "bad_request", "body.activate: expected true or false"};
              }
              const std::string kind = body["kind"].get<std::string>();
              const std::string id = submit_job(kind, params, body.value("activate", false));
              send_json(res, 202, {{"id", id}, {"kind", kind}, {"state", "queued"}});
            }));
  http.Get(R"(/api/jobs/([^/]+))", guarded([this](const httplib::Request& req, httplib::Response& res) {
             const std::string id = path_id(req, "job");
             const std::optional<JobRecord> job = jobs_->get(id);
             if (!job) throw HttpError{404, "not_found", "no job \"" + id + "\""};
             if (job->result_dropped) {  // an old job: its whole record is in the store
               if (std::optional<nlohmann::json> stored = store_->job(id)) {
                 send_json(res, 200, *stored);
                 return;
               }
             }
             send_json(res, 200, job_to_json(*job, true));
           }));
  http.Delete(R"(/api/jobs/([^/]+))", guarded([this](const httplib::Request& req, httplib::Response& res) {
                const std::string id = path_id(req, "job");
                const std::optional<JobState> before = jobs_->cancel(id);
                if (!before) throw HttpError{404, "not_found", "no job \"" + id + "\""};
                if (*before != JobState::queued && *before != JobState::running) {
                  throw HttpError{409, "conflict", "job \"" + id + "\" has already ended (" + job_state_name(*before) + ")"};
                }
                send_json(res, 200, job_to_json(*jobs_->get(id), false));
              }));
  http.Get(R"(/api/jobs/([^/]+)/events)", guarded([this](const httplib::Request& req, httplib::Response& res) {
             const std::string id = path_id(req, "job");
             if (!jobs_->get(id)) throw HttpError{404, "not_found", "no job \"" + id + "\""};
             std::uint64_t after = 0;
             if (req.has_header("Last-Event-ID")) {
               try {
                 after = std::stoull(req.get_header_value("Last-Event-ID"));
               } catch (const std::exception&) {
                 throw HttpError{400, "bad_request", "Last-Event-ID: expected an event number"};
               }
             }
             res.set_header("Cache-Control", "no-cache");
             res.set_chunked_content_provider(
                 "text/event-stream", [this, id, after](std::size_t, httplib::DataSink& sink) mutable {
                   bool ended = false;
                   const std::vector<JobEvent> events =
                       jobs_->events_after(id, after, std::chrono::milliseconds(500), &ended);
                   for (const JobEvent& e : events) {
                     const std::string text = "id: " + std::to_string(e.sequence) + "\nevent: " + e.type +
                                              "\ndata: " + e.data.dump() + "\n\n";
                     if (!sink.write(text.data(), text.size())) return false;
                     after = e.sequence;
                   }
                   if (ended || !running_.load(std::memory_order_relaxed)) {
                     sink.done();
                     return true;
                   }
                   return sink.is_writable();
                 });
           }));
}

// GET/POST /api/records, GET/DELETE /api/records/{id} (ROUTES.md "Records").
void Server::register_record_routes() {
  httplib::Server& http = *http_;
  http.Get("/api/records", guarded([this](const httplib::Request& req, httplib::Response& res) {
             const std::vector<StoredRecord> all = records_->list();
             const std::size_t offset = query_count(req, "offset", 0, all.size());
             const std::size_t limit = query_count(req, "limit", kDefaultPageLimit, kMaxPageLimit);
             nlohmann::json page = nlohmann::json::array();
             for (std::size_t k = offset; k < all.size() && k < offset + limit; ++k) {
               page.push_back(stored_record_to_json(all[k]));
             }
             send_json(res, 200, {{"records", page}, {"total", all.size()}, {"offset", offset}, {"limit", limit}});
           }));
  http.Post("/api/records", guarded([this](const httplib::Request& req, httplib::Response& res) {
              RecordUpload upload;
              upload.content_type = req.is_multipart_form_data() && req.files.size() == 1
                                        ? req.files.begin()->second.content_type
                                        : req.get_header_value("Content-Type");
              for (const auto& [key, value] : req.params) {
                if (key != "fs" && key != "input" && key != "output" && key != "current" && key != "name") {
                  throw HttpError{400, "bad_request", key + ": unknown query parameter (fs, input, output, current, name)"};
                }
              }
              if (req.has_param("fs")) {
                const std::string text = req.get_param_value("fs");
                char* end = nullptr;
                upload.fs = std::strtod(text.c_str(), &end);
                if (text.empty() || *end != '\0' || !std::isfinite(upload.fs) || upload.fs <= 0.0) {
                  throw HttpError{400, "bad_request", "fs: expected a rate in Hz > 0, got \"" + text + "\""};
                }
              }
              if (req.has_param("input")) upload.input = req.get_param_value("input");
              if (req.has_param("output")) upload.output = req.get_param_value("output");
              if (req.has_param("current")) upload.current = req.get_param_value("current");
              const std::string name = req.has_param("name") ? req.get_param_value("name") : "";
              bool created = false;
              const StoredRecord stored = records_->put(body_text(req), upload, name, engine_->fs(), &created);
              send_json(res, created ? 201 : 200, stored_record_to_json(stored));
            }));
  http.Get(R"(/api/records/([^/]+))", guarded([this](const httplib::Request& req, httplib::Response& res) {
             const std::string id = path_id(req, "record");
             const std::optional<StoredRecord> entry = records_->find(id);
             if (!entry) throw HttpError{404, "not_found", "no uploaded record \"" + id + "\""};
             nlohmann::json j = stored_record_to_json(*entry);
             const dsp::Record data = records_->data(id);
             nlohmann::json columns = nlohmann::json::object();
             for (std::size_t c = 0; c < data.columns.size(); ++c) {
               columns[data.names[c]] = models::to_array(data.columns[c]);
             }
             j["data"] = columns;
             send_json(res, 200, j);
           }));
  http.Delete(R"(/api/records/([^/]+))", guarded([this](const httplib::Request& req, httplib::Response& res) {
                const std::string id = path_id(req, "record");
                if (!records_->remove(id)) throw HttpError{404, "not_found", "no uploaded record \"" + id + "\""};
                res.status = 204;
              }));
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

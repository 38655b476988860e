// GET /api/health, /api/status, /api/openapi.json and /metrics (ROUTES.md "Service"): what the service is
// and how it is doing.
#include "api/server.h"

#include "api/metrics_json.h"
#include "api/prometheus.h"
#include "api/routes/route_helpers.h"

namespace panelbass::api {

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
          {"jobs", {{"queued", jobs_->count(JobState::queued)}, {"running", jobs_->count(JobState::running)},
                    {"max_queued", options_.max_queued_jobs}}},
          {"store", {{"path", options_.store.string()}, {"bytes", store_bytes_.load()}, {"models", store_->list().size()},
                     {"records", records_->list().size()}}}};
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

void Server::register_service_routes() {
  httplib::Server& http = *http_;
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

}

}  // namespace panelbass::api

// GET/POST /api/jobs, GET/DELETE /api/jobs/{id}, GET /api/jobs/{id}/events (ROUTES.md "Jobs"): the job
// queue, and each job's progress as a server-sent event stream.
#include "api/server.h"

#include <algorithm>
#include <chrono>

#include "api/request_body.h"
#include "api/routes/route_helpers.h"

namespace panelbass::api {

void Server::register_job_routes() {
  httplib::Server& http = *http_;
  http.Get("/api/jobs", guarded([this](const httplib::Request& req, httplib::Response& res) {
             // Newest first, a page at a time (the list grows with every job the store keeps).
             const std::vector<JobRecord> all = jobs_->list();
             const Page page = query_page(req, all.size());
             nlohmann::json items = nlohmann::json::array();
             for (std::size_t k = page.offset; k < all.size() && k < page.offset + page.limit; ++k) {
               items.push_back(job_to_json(all[all.size() - 1 - k], false));
             }
             send_json(res, 200, page.answer("jobs", std::move(items), all.size()));
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
              const std::string id = submit_job(kind, params, body.contains("activate") ? std::optional<bool>(body["activate"].get<bool>()) : std::nullopt);
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
             // Each open stream holds a connection's thread: a bounded number of them leaves the rest for
             // every other request.
             const int most = std::max(1, std::min(options_.event_streams, options_.http_threads / 2));
             if (open_event_streams_.fetch_add(1) >= most) {
               open_event_streams_.fetch_sub(1);
               res.set_header("Retry-After", "5");
               throw HttpError{503, "unavailable", "too many event streams: " + std::to_string(most) +
                                                        " are open (poll GET /api/jobs/" + id + " instead, or close one)"};
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
                 },
                 [this](bool) { open_event_streams_.fetch_sub(1); });
           }));
}

}  // namespace panelbass::api

// GET/POST /api/records, GET/DELETE /api/records/{id} (ROUTES.md "Records"): uploaded recordings.
#include "api/server.h"

#include <cmath>
#include <cstdlib>

#include "api/record_upload.h"
#include "api/request_body.h"
#include "api/routes/route_helpers.h"
#include "models/io/json_fields.h"

namespace panelbass::api {

void Server::register_record_routes() {
  httplib::Server& http = *http_;
  http.Get("/api/records", guarded([this](const httplib::Request& req, httplib::Response& res) {
             const std::vector<StoredRecord> all = records_->list();
             const Page page = query_page(req, all.size());
             nlohmann::json items = nlohmann::json::array();
             for (std::size_t k = page.offset; k < all.size() && k < page.offset + page.limit; ++k) {
               items.push_back(stored_record_to_json(all[k]));
             }
             send_json(res, 200, page.answer("records", std::move(items), all.size()));
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
              if (req.has_param("input")) upload.input = query_text(req, "input");
              if (req.has_param("output")) upload.output = query_text(req, "output");
              if (req.has_param("current")) upload.current = query_text(req, "current");
              const std::string name = query_text(req, "name");
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

}  // namespace panelbass::api

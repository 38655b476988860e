// GET/PUT/PATCH /api/config (ROUTES.md "Config"): the engine's settings, changed without interruption.
#include "api/server.h"

#include "api/request_body.h"
#include "api/routes/route_helpers.h"

namespace panelbass::api {

void Server::register_config_routes() {
  httplib::Server& http = *http_;
  const ModelLookup lookup = [this](const std::string& id) { return store_->model(id); };

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
}

}  // namespace panelbass::api

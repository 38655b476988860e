// GET/PUT /api/program (ROUTES.md "Program"): what the engine loops as its program, replaced with a fade.
#include "api/server.h"

#include "api/request_body.h"
#include "api/routes/route_helpers.h"

namespace panelbass::api {

void Server::register_program_routes() {
  httplib::Server& http = *http_;
  http.Get("/api/program", guarded([this](const httplib::Request&, httplib::Response& res) {
             send_json(res, 200, engine_->program());
           }));
  http.Put("/api/program", guarded([this](const httplib::Request& req, httplib::Response& res) {
             const nlohmann::json request =
                 parse_body(req, "the program to loop, e.g. {\"signal\":\"sine:80\",\"amplitude\":0.2}");
             send_json(res, 200, engine_->put_program(request));
           }));
}

}  // namespace panelbass::api

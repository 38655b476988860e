// GET/POST /api/models, GET/DELETE /api/models/{id}, POST /api/models/{id}/activate (ROUTES.md "Models"):
// the store's models and the engine's slots they run in.
#include "api/server.h"

#include "api/model_validation.h"
#include "api/request_body.h"
#include "api/routes/route_helpers.h"
#include "dsp/sample_rate.h"
#include "models/io/number_text.h"

namespace panelbass::api {
namespace {

// The largest `meta` (free-form notes) a model may carry, as JSON text.
constexpr std::size_t kMaxMetaBytes = 64u << 10;

}  // namespace

void Server::register_model_routes() {
  httplib::Server& http = *http_;
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
              const std::string name = query_text(req, "name");
              if (const auto meta = model.find("meta"); meta != model.end()) {
                // Free-form notes travel with the model into the store, every listing and every restart.
                const std::size_t bytes = meta->dump().size();
                if (bytes > kMaxMetaBytes) {
                  throw HttpError{422, "invalid_model", "model.meta: " + size_text(bytes) + " of JSON, at most " +
                                                            size_text(kMaxMetaBytes)};
                }
              }
              const ValidatedModel valid = validate_model(model);
              if (!dsp::same_rate(valid.fs, engine_->fs())) {
                throw HttpError{422, "invalid_model",
                                "model.fs: the model runs at " + models::number_text(valid.fs) + " Hz, the engine at " +
                                    models::number_text(engine_->fs()) + " Hz"};
              }
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
}

}  // namespace panelbass::api

#include "api/jobs/stored_models.h"

#include <algorithm>
#include <optional>
#include <stdexcept>

#include "api/model_store.h"
#include "api/model_validation.h"
#include "dsp/sample_rate.h"
#include "models/io/number_text.h"

namespace panelbass::api {

using nlohmann::json;

void require_stored_model(ParamReader& r, const std::string& key, bool required, const std::vector<std::string>& kinds,
                          const JobEnvironment& env) {
  const std::optional<std::string> id = r.id(key, required);
  if (id) require_stored_id(*id, r.path_of(key), kinds, env);
}

void require_stored_id(const std::string& id, const std::string& where, const std::vector<std::string>& kinds,
                       const JobEnvironment& env) {
  if (env.store == nullptr) refuse(where, "no model store to read \"" + id + "\" from");
  const std::optional<StoredModel> stored = env.store->find(id);
  if (!stored) refuse(where, "no stored model \"" + id + "\"");
  if (std::find(kinds.begin(), kinds.end(), stored->kind) == kinds.end()) {
    std::string expected;
    for (std::size_t k = 0; k < kinds.size(); ++k) expected += (k ? " or " : "") + kinds[k];
    refuse(where, "model " + id + " is of kind \"" + stored->kind + "\", expected " + expected);
  }
  if (!dsp::same_rate(stored->fs, env.fs)) {
    refuse(where, "model " + id + " runs at " + models::number_text(stored->fs) + " Hz, the engine at " +
                      models::number_text(env.fs) + " Hz");
  }
}

std::vector<std::string> kinds_taking(models::ModelRole role) {
  std::vector<std::string> names;
  for (const models::ModelKind& k : models::model_kinds()) {
    if (k.takes(role)) names.emplace_back(k.name);
  }
  return names;
}

json stored_model_file(const JobEnvironment& env, const std::string& id) {
  if (env.store == nullptr) throw std::runtime_error("no model store");
  std::optional<json> model = env.store->model(id);
  if (!model) throw std::runtime_error("model " + id + " is no longer stored");
  return *model;
}

std::string store_model(const JobEnvironment& env, const json& model, const std::string& name, const JobControl& control) {
  if (env.store == nullptr) throw std::runtime_error("no model store to keep the model in");
  const ValidatedModel valid = validate_model(model);
  return env.store->put(model, valid.kind, valid.fs, name, control.job_id()).id;
}

}  // namespace panelbass::api

#pragma once
// The models a job names and the model it makes: the params check of a stored model's id, reading it back
// when the job runs, and storing a new model with the job as its source.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "api/job_queue.h"
#include "api/jobs/job_environment.h"
#include "api/jobs/param_reader.h"
#include "models/kinds/model_file.h"

namespace panelbass::api {

/// Reads the id at `key` of `r` (required or not) and checks that the store holds it, of one of `kinds`, at
/// the engine's rate; std::invalid_argument naming the field otherwise.
void require_stored_model(ParamReader& r, const std::string& key, bool required, const std::vector<std::string>& kinds,
                          const JobEnvironment& env);

/// Checks that the store holds `id`, of one of `kinds`, at the engine's rate; std::invalid_argument "<where>: …".
void require_stored_id(const std::string& id, const std::string& where, const std::vector<std::string>& kinds,
                       const JobEnvironment& env);
/// The names of the model kinds that may take `role` (the registry's), for require_stored_model.
std::vector<std::string> kinds_taking(models::ModelRole role);

/// The stored model file `id` (checked when the params were; gone since → std::runtime_error, the job fails).
nlohmann::json stored_model_file(const JobEnvironment& env, const std::string& id);

/// Validates `model` and stores it as `name` with the job of `control` as its source; returns its id.
std::string store_model(const JobEnvironment& env, const nlohmann::json& model, const std::string& name,
                        const JobControl& control);

}  // namespace panelbass::api

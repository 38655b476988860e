#pragma once
// The kinds of job the API runs (ROUTES.md "Jobs"): excite, identify-linear, identify-narx, design-lq,
// design-nn, evaluate, analyze, diagnose. Each validates its params before it is queued and returns a result with
// plot-ready columns.

#include <Eigen/Core>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "api/job_queue.h"
#include "api/model_store.h"
#include "models/plant/plant_config.h"

namespace panelbass::api {

/// What a job may use of the running service.
struct JobEnvironment {
  double fs = 3000.0;  ///< the engine's rate (every model a job makes runs at it)
  /// Plays `drive` (raw drive units, within [−1, 1]) through the active backend, bypassing the chain, and
  /// returns the recorded response, same length. Called from a worker thread.
  std::function<Eigen::VectorXd(const Eigen::VectorXd& drive)> excite;
  /// The virtual transducer when that is the backend (harmonic distortion, noise floor); empty otherwise.
  std::optional<models::PlantConfig> plant;
  /// The store: models a job reads ("plant_model", …) and the model it makes.
  ModelStore* store = nullptr;
  /// The result of a finished job (the "record" param of identify/analyze/diagnose); nullopt if unknown
  /// or not succeeded.
  std::function<std::optional<nlohmann::json>(const std::string& job_id)> job_result;
};

/// The job kinds, in the order ROUTES.md lists them.
const std::vector<std::string>& job_kinds();

/// Checks `params` of `kind` without running anything: unknown kind, unknown fields (named), wrong types,
/// values out of range, referenced models or jobs that do not exist or are of the wrong kind. Returns the
/// params with defaults filled in. Throws std::invalid_argument with "params.<field>: …" (or "kind: …").
nlohmann::json validate_job_params(const std::string& kind, const nlohmann::json& params, const JobEnvironment& env);

/// The work of `kind` (params already validated). A job that makes a model stores it (validated, source
/// = control.job_id()) and returns "model_id" in its result.
JobWork job_work(const std::string& kind, const JobEnvironment& env);

}  // namespace panelbass::api

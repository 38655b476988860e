#pragma once
// One kind of job as the registry (job_kinds) holds it: its name, its params check and its work.

#include <nlohmann/json.hpp>

#include "api/job_queue.h"
#include "api/jobs/job_environment.h"

namespace panelbass::api {

/// Checks a kind's params against `env` and returns them with defaults filled in; throws
/// std::invalid_argument naming the field ("params.<field>: …").
using ParamsCheck = nlohmann::json (*)(const nlohmann::json& params, const JobEnvironment& env);

/// A kind's work on params that passed its check; reports progress (and is cancelled) through `control`.
using KindWork = nlohmann::json (*)(const nlohmann::json& params, const JobEnvironment& env, JobControl& control);

/// One kind of job.
struct JobKind {
  const char* name;    ///< as ROUTES.md spells it ("identify-linear")
  ParamsCheck params;  ///< its params check
  KindWork work;       ///< its work
  const char* makes = nullptr;  ///< the model kind its result's "model_id" is of (nullptr: it makes none)
  /// Its result's "model_id" (null when it kept none) is activated unless the request says "activate": false
  /// (tune: what it verified to help joins the chain).
  bool activates_by_default = false;
};

}  // namespace panelbass::api

#pragma once
// The kinds of job the API runs (ROUTES.md "Jobs"): excite, identify-linear, identify-narx, identify-oscillator, validate, design-lq,
// design-nn, design-mirror, evaluate, analyze, harmonics, diagnose, verify, tune. Each validates its params before it is queued and returns a result with
// plot-ready columns. Each kind is a file of its own here (its params beside its work); this is the registry.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "api/job_queue.h"
#include "api/jobs/job_environment.h"

namespace panelbass::api {

/// The job kinds, in the order ROUTES.md lists them.
const std::vector<std::string>& job_kinds();

/// The model kind a job of `job_kind` makes ("" when it makes none, or the job kind is unknown).
std::string model_kind_made_by(const std::string& job_kind);

/// True when a job of `job_kind` activates the model it keeps unless asked not to (JobKind::activates_by_default).
bool activates_by_default(const std::string& job_kind);

/// Checks `params` of `kind` without running anything: unknown kind, unknown fields (named), wrong types,
/// values out of range, referenced models or jobs that do not exist or are of the wrong kind. Returns the
/// params with defaults filled in. Throws std::invalid_argument with "params.<field>: …" (or "kind: …").
nlohmann::json validate_job_params(const std::string& kind, const nlohmann::json& params, const JobEnvironment& env);

/// The work of `kind` (params already validated). A job that makes a model stores it (validated, source
/// = control.job_id()) and returns "model_id" in its result.
JobWork job_work(const std::string& kind, const JobEnvironment& env);

}  // namespace panelbass::api

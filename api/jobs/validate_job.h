#pragma once
// The validate job kind (ROUTES.md "Jobs"): `panelbass validate` over the API.

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// {"model":"m…" (a plant model), record|excite, "init":0}: J by free-run simulation and one-step prediction.
JobKind validate_job();

}  // namespace panelbass::api

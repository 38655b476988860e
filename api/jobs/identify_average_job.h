#pragma once
// The identify-average job kind (ROUTES.md "Jobs"): `panelbass identify average` over the API.

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// {"models":["m…",…] (stored ss models),record|excite (optional: the validation part chooses the members),
/// "init":50}: the average of the chosen members stored as one ss model.
JobKind identify_average_job();

}  // namespace panelbass::api

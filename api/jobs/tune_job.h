#pragma once
// The tune job kind (ROUTES.md "Jobs", issue #56): usecases/tune.h through the server's backend — measure,
// the gray-box model from the coil current, the mirror filter, verify at equal output level — and the filter
// activated into the feedforward slot when verify shows it helps.

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// {"sensor_kind":"none","frequencies":[40,80,160],"levels":[0.1,0.2,0.3],…}: every field has a default.
JobKind tune_job();

}  // namespace panelbass::api

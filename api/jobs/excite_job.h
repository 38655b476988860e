#pragma once
// The excite job: plays an excitation through the backend and keeps its record for later jobs

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// The excite job: its params check and its work.
JobKind excite_job();

}  // namespace panelbass::api

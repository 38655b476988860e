#pragma once
// The identify-narx job: a NARX network trained on a record (PEM, OEM), optionally weighted and friction-seeded

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// The identify-narx job: its params check and its work.
JobKind identify_narx_job();

}  // namespace panelbass::api

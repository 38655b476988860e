#pragma once
// The evaluate job: a chain of stored controllers evaluated on a virtual transducer, optionally term by term

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// The evaluate job: its params check and its work.
JobKind evaluate_job();

}  // namespace panelbass::api

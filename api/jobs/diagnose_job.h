#pragma once
// The diagnose job: where a simulation and a record disagree, the physics it leaves out, and J before and after

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// The diagnose job: its params check and its work.
JobKind diagnose_job();

}  // namespace panelbass::api

#pragma once
// The design-nn job: a neural feedback controller trained in closed loop with a stored NARX plant model

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// The design-nn job: its params check and its work.
JobKind design_nn_job();

}  // namespace panelbass::api

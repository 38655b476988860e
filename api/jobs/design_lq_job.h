#pragma once
// The design-lq job: an LQ feedforward controller [7A]/[7B] on a stored linear model, behind a band-pass

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// The design-lq job: its params check and its work.
JobKind design_lq_job();

}  // namespace panelbass::api

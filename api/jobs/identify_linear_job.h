#pragma once
// The identify-linear job: a linear model (FIR, ARX, OE, Zhu, FIR → Hankel → OE) of a record, with an
// optional order scan

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// The identify-linear job: its params check and its work.
JobKind identify_linear_job();

}  // namespace panelbass::api

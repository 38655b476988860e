#pragma once
// The identify-ss job kind (ROUTES.md "Jobs"): `panelbass identify ss` over the API.

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// {record|excite,"linear":"m…","start_from":"m…","nx":6,"hidden":20,"lags":50,"window":100,"epochs":100,…}: the
/// neural state-space model trained from the best linear model, the epoch of the lowest selection J stored.
JobKind identify_ss_job();

}  // namespace panelbass::api

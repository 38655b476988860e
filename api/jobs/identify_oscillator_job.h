#pragma once
// The identify-oscillator job kind (ROUTES.md "Jobs"): `panelbass identify oscillator` over the API.

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// {record|excite,"terms":["y3"],"substeps":4,"output_taps":0,"input_taps":0,"max_iterations":200,"init":50,
/// "delay":true}: the oscillator fitted in stages, the stage of the lowest validation J stored.
JobKind identify_oscillator_job();

}  // namespace panelbass::api

#pragma once
// The design-mirror job kind (ROUTES.md "Jobs"): `panelbass design mirror` over the API.

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// {"samples":30000,"amplitude":0.5,"f_min":10,"f_max":300,"seed":1,"max_delay":4,"adapt":false,…}: the server's
/// virtual transducer excited by a multisine, its drive, current and displacement fitted, the mirror filter stored.
JobKind design_mirror_job();

}  // namespace panelbass::api

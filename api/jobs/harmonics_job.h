#pragma once
// The harmonics job kind (ROUTES.md "Jobs"): `panelbass harmonics` over the API.

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// {"model":"m…" (optional, a plant model),"frequencies":[…],"amplitudes":[0.8],"noise":false,"settle":600,
/// "measure":3000}: stepped sines through the server's virtual transducer (its physics) or played through the sound
/// card, and the model beside it.
JobKind harmonics_job();

}  // namespace panelbass::api

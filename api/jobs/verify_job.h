#pragma once
// The verify job: probe tones played through the backend (a sound card or the virtual transducer) twice —
// as they are, then as the chain with the given controllers makes its drive of them — and the THD and level
// of the measured response each time, so a user sees and hears what the chain changed.

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// The verify job: its params check and its work.
JobKind verify_job();

}  // namespace panelbass::api

#pragma once
// The analyze job: the analysis report of a stored model on a record (fit, spectra, residual tests, history)

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// The analyze job: its params check and its work.
JobKind analyze_job();

}  // namespace panelbass::api

#pragma once
// The identify-mimo job kind (ROUTES.md "Jobs"): `panelbass identify mimo` over the API.

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// {"record":"r…" (an uploaded periodic CSV: realization, period, the inputs and outputs),"inputs":["u1","u2","u3"],
/// "outputs":["y1","y2","y3"],"order":0,"taps":150,"ridge":1e-6,"max_iterations":100,"val_realizations":1}: the
/// multi-input multi-output state space identified from the record's periodic steady state; the result holds the
/// mimo model file ("model"), a kind the model store does not keep.
JobKind identify_mimo_job();

}  // namespace panelbass::api

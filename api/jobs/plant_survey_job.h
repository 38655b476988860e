#pragma once
// The plant-survey job kind (ROUTES.md "Jobs"): `panelbass plant survey` over the API.

#include "api/jobs/job_kind.h"

namespace panelbass::api {

/// {"plant":"server"|preset,"seed":1,"samples":10000,"amplitude":1}: the server's virtual transducer (the default
/// when it runs one) or a preset measured from simulated data (usecases/plant_survey.h).
JobKind plant_survey_job();

}  // namespace panelbass::api

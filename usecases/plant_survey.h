#pragma once
// `plant survey` / the plant-survey job: a virtual transducer measured the way the thesis measured its prototype,
// from simulated data only (never from its configuration): delay, impulse length, resonances, notch, a linear
// model's J against the sensor noise's, and the harmonic distortion (models/plant/plant_survey.h).

#include <cstdint>
#include <nlohmann/json.hpp>

#include "models/plant/plant_config.h"
#include "models/plant/plant_survey.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// What `plant survey` is asked.
struct PlantSurveyRequest {
  models::PlantConfig plant;                               ///< the transducer surveyed (a preset, a file, the server's)
  std::uint64_t seed = models::PlantSurveySpec{}.seed;     ///< seed of the excitations (the sensor noise: seed + 1)
  long samples = static_cast<long>(models::PlantSurveySpec{}.estimation_samples);  ///< estimation noise, 1000..10 000 000
  double amplitude = models::PlantSurveySpec{}.amplitude;  ///< peak drive of the noise, (0, 1]
};

/// What the survey measured.
struct PlantSurveyReport {
  /// models::survey_to_json's figures ("delay_samples", "main_resonance_hz", "J_linear_val_pct", "distortion", …)
  /// with the "plant" surveyed and the "seed".
  nlohmann::json summary;
};

/// Throws RequestError naming the field for a request out of range.
void check(const PlantSurveyRequest& request);

/// The request's fields (the plant by its name), as the API echoes its params.
nlohmann::json to_json(const PlantSurveyRequest& request);

/// Surveys the plant.
PlantSurveyReport survey_plant(const PlantSurveyRequest& request, Progress& progress);

}  // namespace panelbass::usecases

#include "usecases/plant_survey.h"

#include "models/io/number_text.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {

void check(const PlantSurveyRequest& q) {
  if (q.samples < 1000 || q.samples > 10000000) {
    throw RequestError("samples", "must be within 1000..10000000, got " + std::to_string(q.samples));
  }
  if (!(q.amplitude > 0.0 && q.amplitude <= 1.0)) {
    throw RequestError("amplitude", "must be within (0, 1], got " + models::number_text(q.amplitude));
  }
}

nlohmann::json to_json(const PlantSurveyRequest& q) {
  return {{"plant", q.plant.name}, {"seed", q.seed}, {"samples", q.samples}, {"amplitude", q.amplitude}};
}

PlantSurveyReport survey_plant(const PlantSurveyRequest& q, Progress& progress) {
  check(q);
  progress.report(0.0, "surveying " + q.plant.name);
  models::PlantSurveySpec spec;
  spec.seed = q.seed;
  spec.estimation_samples = static_cast<std::size_t>(q.samples);
  spec.amplitude = q.amplitude;
  PlantSurveyReport report;
  report.summary = models::survey_to_json(models::survey_plant(q.plant, spec));
  report.summary["plant"] = q.plant.name;
  report.summary["seed"] = q.seed;
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases

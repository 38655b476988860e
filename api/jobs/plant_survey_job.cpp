#include "api/jobs/plant_survey_job.h"

#include <string>
#include <vector>

#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "models/plant/plant_presets.h"
#include "usecases/plant_survey.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The request of filled-in params: "server" is the server's own virtual transducer, else a preset.
usecases::PlantSurveyRequest survey_request(const json& params, const JobEnvironment& env) {
  usecases::PlantSurveyRequest q;
  const std::string plant = params.at("plant").get<std::string>();
  q.plant = plant == "server" ? *env.plant : models::plant_preset(plant);
  q.seed = params.at("seed").get<std::uint64_t>();
  q.samples = params.at("samples").get<long>();
  q.amplitude = params.at("amplitude").get<double>();
  return q;
}

json plant_survey_params(const json& params, const JobEnvironment& env) {
  const usecases::PlantSurveyRequest defaults;
  ParamReader r(params, "params");
  std::vector<std::string> plants = models::plant_preset_names();
  if (env.plant) plants.insert(plants.begin(), "server");
  r.choice("plant", plants.front(), plants);
  r.integer("seed", static_cast<long long>(defaults.seed), 0, kMaxSeed);
  r.integer("samples", defaults.samples, -kAnyInteger, kAnyInteger);
  r.number("amplitude", defaults.amplitude, kAnyFinite);
  json filled = r.finish();
  check_request([&] { usecases::check(survey_request(filled, env)); });
  return filled;
}

json plant_survey_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const usecases::PlantSurveyRequest q = survey_request(params, env);
  usecases::PlantSurveyReport report;
  check_request([&] { report = usecases::survey_plant(q, progress); });
  return {{"summary", report.summary}};
}

}  // namespace

JobKind plant_survey_job() { return {"plant-survey", plant_survey_params, plant_survey_work}; }

}  // namespace panelbass::api

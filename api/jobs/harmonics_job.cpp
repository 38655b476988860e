#include "api/jobs/harmonics_job.h"

#include <limits>
#include <string>

#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/stored_models.h"
#include "usecases/harmonics.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

constexpr long long kAnyCount = std::numeric_limits<long>::max();

// The request of filled-in params on `env`'s backend (the model read from the store when `with_model`).
usecases::HarmonicsRequest harmonics_request(const json& params, const JobEnvironment& env, bool with_model) {
  usecases::HarmonicsRequest q;
  q.frequencies = params.at("frequencies").get<std::vector<double>>();
  q.amplitudes = params.at("amplitudes").get<std::vector<double>>();
  q.noise = params.at("noise").get<bool>();
  q.settle = params.at("settle").get<long>();
  q.measure = params.at("measure").get<long>();
  if (const json& model = params.at("model"); !model.is_null()) {
    q.model_name = model.get<std::string>();
    q.model = with_model ? stored_model_file(env, q.model_name) : json::object();
  }
  if (env.plant) {
    q.plant = env.plant;
    q.source_name = "the server's virtual transducer";
  } else {
    q.system = env.excite;
    q.fs = env.fs;
    q.source_name = "the sound card";
  }
  return q;
}

json harmonics_params(const json& params, const JobEnvironment& env) {
  const usecases::HarmonicsRequest defaults;
  ParamReader r(params, "params");
  require_stored_model(r, "model", false, kinds_taking(models::ModelRole::plant), env);
  if (r.member("model") == nullptr || r.member("model")->is_null()) r.set("model", nullptr);
  r.numbers("frequencies", defaults.frequencies, 1, 64, kAnyFinite);
  r.numbers("amplitudes", defaults.amplitudes, 1, 16, {0.0, env.safe_level, true, false});
  r.boolean("noise", defaults.noise);
  r.integer("settle", defaults.settle, -kAnyCount, kAnyCount);
  r.integer("measure", defaults.measure, -kAnyCount, kAnyCount);
  json filled = r.finish();
  check_request([&] { usecases::check(harmonics_request(filled, env, false)); });
  return filled;
}

json harmonics_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const usecases::HarmonicsRequest q = harmonics_request(params, env, true);
  json summary;
  check_request([&] { summary = usecases::harmonics(q, progress); });
  return {{"j_est_pct", nullptr}, {"j_val_pct", nullptr}, {"summary", summary}, {"plots", json::object()}};
}

}  // namespace

JobKind harmonics_job() { return {"harmonics", harmonics_params, harmonics_work}; }

}  // namespace panelbass::api

#include "api/jobs/verify_job.h"

#include <algorithm>
#include <string>
#include <vector>

#include "api/jobs/backend_play.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/stored_models.h"
#include "usecases/verify.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The request of filled-in params: the running chain and the backend's rate and safe level from `env`, the models read
// from the store when `with_models` (the params check has only their ids).
usecases::VerifyRequest verify_request(const json& p, const JobEnvironment& env, bool with_models) {
  usecases::VerifyRequest q;
  q.feedforward_name = p.at("feedforward_model").get<std::string>();
  if (with_models) q.feedforward_model = stored_model_file(env, q.feedforward_name);
  if (const json fb = p.value("feedback_model", json(nullptr)); fb.is_string()) {
    q.feedback_name = fb.get<std::string>();
    if (with_models) q.feedback_model = stored_model_file(env, q.feedback_name);
  }
  q.chain = env.chain ? env.chain() : engine::ChainConfig{};
  q.chain.fs = env.fs;
  q.safe_level = env.safe_level;
  q.settings.frequencies = p.at("frequencies").get<std::vector<double>>();
  q.settings.levels = p.at("levels").get<std::vector<double>>();
  q.settings.settle_seconds = p.at("settle_seconds").get<double>();
  q.settings.analysis_seconds = p.at("analysis_seconds").get<double>();
  q.settings.max_plays = p.at("max_plays").get<int>();
  return q;
}

json verify_params(const json& params, const JobEnvironment& env) {
  if (!env.excite && !env.measure) refuse("params", "this server has no backend to play the probe tones through");
  const usecases::VerifyRequest defaults;
  std::vector<double> levels = defaults.settings.levels;  // below the backend's safe level
  for (double& level : levels) level = std::min(level, env.safe_level);
  ParamReader r(params, "params");
  require_stored_model(r, "feedforward_model", true, kinds_taking(models::ModelRole::feedforward), env);
  require_stored_model(r, "feedback_model", false, kinds_taking(models::ModelRole::feedback), env);
  // The ranges are the use case's (usecases::check of EqualOutputSettings): the same words as `panelbass verify`.
  constexpr std::size_t kAnyCount = 1000;
  r.numbers("frequencies", defaults.settings.frequencies, 0, kAnyCount, kAnyFinite);
  r.numbers("levels", levels, 0, kAnyCount, kAnyFinite);
  r.number("settle_seconds", defaults.settings.settle_seconds, kAnyFinite);
  r.number("analysis_seconds", defaults.settings.analysis_seconds, kAnyFinite);
  r.integer("max_plays", defaults.settings.max_plays, -kAnyInteger, kAnyInteger);
  json filled = r.finish();
  check_request([&] { usecases::check(verify_request(filled, env, false)); });
  return filled;
}

json verify_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  usecases::EqualOutputReport report;
  check_request([&] {
    report = usecases::verify(verify_request(params, env, true), backend_play(env, PlayedChannels::sensor, 1), progress);
  });
  json result = report.to_json();
  result["fs"] = env.fs;
  result["backend"] = env.measure ? "alsa" : "virtual";
  result["plots"] = report.plots();
  return result;
}

}  // namespace

JobKind verify_job() { return {"verify", verify_params, verify_work}; }

}  // namespace panelbass::api

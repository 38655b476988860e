#include "api/jobs/verify_job.h"

#include <algorithm>
#include <string>
#include <vector>

#include "api/jobs/backend_play.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/lq_band_pass.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/stored_models.h"
#include "models/control/lq_feedforward.h"
#include "usecases/equal_output_thd.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

json verify_params(const json& params, const JobEnvironment& env) {
  if (!env.excite && !env.measure) refuse("params", "this server has no backend to play the probe tones through");
  const usecases::EqualOutputSettings defaults;
  ParamReader r(params, "params");
  require_stored_model(r, "feedforward_model", true, kinds_taking(models::ModelRole::feedforward), env);
  require_stored_model(r, "feedback_model", false, kinds_taking(models::ModelRole::feedback), env);
  r.numbers("frequencies", defaults.frequencies, 1, 16, {10.0, env.fs / 4.0, true, true});
  r.numbers("levels", {std::min(0.2, env.safe_level)}, 1, 16, {0.0, 1.0, false, true});
  r.number("settle_seconds", defaults.settle_seconds, {0.1, 5.0, true, true});
  r.number("analysis_seconds", defaults.analysis_seconds, {0.2, 10.0, true, true});
  r.integer("max_plays", defaults.max_plays, 1, 8);
  return r.finish();
}

// The chain verified: the engine's (its band-pass and limiter) with the feedforward in its slot — behind the band-pass
// an LQ feedforward was designed for — and the feedback in model mode when given.
engine::ChainConfig verified_chain(const json& feedforward, const json* feedback, const JobEnvironment& env) {
  engine::ChainConfig chain = env.chain ? env.chain() : engine::ChainConfig{};
  chain.fs = env.fs;
  if (feedforward.value("kind", "") == "lq_feedforward") {
    const LqBandPass band = lq_band_pass(models::lq_feedforward_from_json(feedforward));
    chain.band_pass.design.low = engine::Hertz{band.low_hz};
    chain.band_pass.design.high = engine::Hertz{band.high_hz};
    chain.band_pass.design.order = band.order;
  }
  chain.band_pass.bypass = false;
  chain.feedforward = engine::SlotConfig{};
  chain.feedforward->model = feedforward;
  chain.feedback.reset();
  if (feedback != nullptr) {
    chain.feedback = engine::SlotConfig{};
    chain.feedback->model = *feedback;
    chain.feedback->source = engine::FeedbackSource::model;
  }
  return chain;
}

json verify_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const json feedforward = stored_model_file(env, params.at("feedforward_model").get<std::string>());
  const json feedback_file = params.contains("feedback_model") && params.at("feedback_model").is_string()
                                 ? stored_model_file(env, params.at("feedback_model").get<std::string>())
                                 : json();
  usecases::EqualOutputRequest q;
  q.chain = verified_chain(feedforward, feedback_file.is_null() ? nullptr : &feedback_file, env);
  q.safe_level = env.safe_level;
  q.settings.frequencies = params.at("frequencies").get<std::vector<double>>();
  q.settings.levels = params.at("levels").get<std::vector<double>>();
  q.settings.settle_seconds = params.at("settle_seconds").get<double>();
  q.settings.analysis_seconds = params.at("analysis_seconds").get<double>();
  q.settings.max_plays = params.at("max_plays").get<int>();
  const usecases::EqualOutputReport report =
      usecases::verify_equal_output(q, backend_play(env, PlayedChannels::sensor, 1), progress);
  json result = report.to_json();
  result["fs"] = env.fs;
  result["backend"] = env.measure ? "alsa" : "virtual";
  result["plots"] = report.plots();
  return result;
}

}  // namespace

JobKind verify_job() { return {"verify", verify_params, verify_work}; }

}  // namespace panelbass::api

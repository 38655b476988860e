#include "api/jobs/tune_job.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

#include "api/jobs/backend_play.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/stored_models.h"
#include "usecases/tune.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The request from checked params (the running chain and the backend's rate and safe level from `env`).
usecases::TuneRequest request_of(const json& p, const JobEnvironment& env) {
  usecases::TuneRequest q;
  q.chain = env.chain ? env.chain() : engine::ChainConfig{};
  q.chain.fs = env.fs;
  q.safe_level = env.safe_level;
  q.samples = p.at("samples").get<long long>();
  q.amplitude = p.at("amplitude").get<double>();
  q.f_min = p.at("f_min").get<double>();
  q.f_max = p.at("f_max").get<double>();
  q.seed = p.at("seed").get<std::uint64_t>();
  q.sensor_kind = p.at("sensor_kind").get<std::string>();
  q.max_delay = p.at("max_delay").get<int>();
  q.verify.frequencies = p.at("frequencies").get<std::vector<double>>();
  q.verify.levels = p.at("levels").get<std::vector<double>>();
  q.verify.settle_seconds = p.at("settle_seconds").get<double>();
  q.verify.analysis_seconds = p.at("analysis_seconds").get<double>();
  q.verify.max_plays = p.at("max_plays").get<int>();
  q.keep_min_cut_db = p.at("keep_min_cut_db").get<double>();
  q.refine_friction = p.at("refine_friction").get<bool>();
  return q;
}

json tune_params(const json& params, const JobEnvironment& env) {
  if (!env.measure && !env.plant) refuse("params", "this server has no backend to measure the transducer through");
  const usecases::TuneRequest defaults;
  ParamReader r(params, "params");
  // The ranges are the use case's (usecases::check of TuneRequest): the same words as `panelbass tune`.
  constexpr std::size_t kAnyCount = 1000;
  r.integer("samples", defaults.samples, -kAnyInteger, kAnyInteger);
  r.number("amplitude", std::min(defaults.amplitude, env.safe_level), kAnyFinite);
  r.number("f_min", defaults.f_min, kAnyFinite);
  r.number("f_max", defaults.f_max, kAnyFinite);
  r.integer("seed", static_cast<long long>(defaults.seed), 0, kMaxSeed);
  r.choice("sensor_kind", defaults.sensor_kind, {"none", "acceleration", "velocity", "displacement", "microphone"});
  r.integer("max_delay", defaults.max_delay, -kAnyInteger, kAnyInteger);
  r.numbers("frequencies", defaults.verify.frequencies, 0, kAnyCount, kAnyFinite);
  r.numbers("levels", defaults.verify.levels, 0, kAnyCount, kAnyFinite);
  r.number("settle_seconds", defaults.verify.settle_seconds, kAnyFinite);
  r.number("analysis_seconds", defaults.verify.analysis_seconds, kAnyFinite);
  r.integer("max_plays", defaults.verify.max_plays, -kAnyInteger, kAnyInteger);
  r.number("keep_min_cut_db", defaults.keep_min_cut_db, kAnyFinite);
  r.boolean("refine_friction", defaults.refine_friction);
  json filled = r.finish();
  check_request([&] { usecases::check(request_of(filled, env)); });
  return filled;
}

json tune_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const usecases::TuneRequest q = request_of(params, env);
  const usecases::PlayFunction play = backend_play(env, PlayedChannels::sensor_and_current, q.seed + 1000);
  usecases::TuneReport report = usecases::tune(q, play, progress);
  json result = report.to_json();
  const std::string mirror_id = store_model(env, models::mirror_model_to_json(report.mirror->model, report.mirror->meta),
                                            std::string(report.keep ? "mirror filter" : "mirror filter, left out") + " (" +
                                                control.job_id() + ")",
                                            control);
  result["mirror_model_id"] = mirror_id;
  result["model_id"] = report.keep ? json(mirror_id) : json(nullptr);  // activated by the server when kept
  result["backend"] = env.measure ? "alsa" : "virtual";
  result["summary"] = report.mirror->summary;
  result["plots"] = report.verify ? report.verify->plots() : json(nullptr);
  return result;
}

}  // namespace

JobKind tune_job() {
  JobKind kind{"tune", tune_params, tune_work, "mirror_filter"};
  kind.activates_by_default = true;
  return kind;
}

}  // namespace panelbass::api

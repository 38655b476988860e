#include "api/jobs/design_lq_job.h"

#include <limits>
#include <string>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/stored_models.h"
#include "models/io/number_text.h"
#include "usecases/design_lq.h"

namespace panelbass::api {
namespace {

using nlohmann::json;


// The request of filled-in params; the plant model's file read from the store when `env` has it.
usecases::DesignLqRequest design_lq_request(const json& params, const JobEnvironment& env, bool with_model) {
  usecases::DesignLqRequest q;
  q.plant_name = params.at("plant_model").get<std::string>();
  if (with_model) q.plant_model = stored_model_file(env, q.plant_name);
  if (!params.at("r").is_null()) q.r = params.at("r").get<double>();
  if (!params.at("max_input").is_null()) q.max_input = params.at("max_input").get<double>();
  q.r0 = params.at("r0").get<double>();
  const json& band = params.at("band_pass");
  q.band_pass = {band.at("low_hz").get<double>(), band.at("high_hz").get<double>(), band.at("order").get<int>()};
  if (const json& t = params.at("target_highpass"); !t.is_null()) {
    q.target_highpass = usecases::TargetHighpass{t.at("hz").get<double>(), t.at("order").get<int>()};
  }
  q.noise_samples = params.at("noise_samples").get<long>();
  q.seed = params.at("seed").get<std::uint64_t>();
  return q;
}

json design_lq_params(const json& params, const JobEnvironment& env) {
  const usecases::DesignLqRequest defaults;
  ParamReader r(params, "params");
  require_stored_model(r, "plant_model", true, {"linear", "gray_box", "ss"}, env);
  for (const char* key : {"r", "max_input"}) {
    const json* v = r.member(key);
    r.set(key, v == nullptr || v->is_null() ? json(nullptr) : json(r.number(key, 0.0, kAnyFinite)));
  }
  r.number("r0", defaults.r0, kAnyFinite);
  const json* band = r.member("band_pass");
  ParamReader b(band != nullptr ? *band : json::object(), r.path_of("band_pass"));
  b.number("low_hz", defaults.band_pass.low_hz, kAnyFinite);
  b.number("high_hz", defaults.band_pass.high_hz, kAnyFinite);
  b.integer("order", defaults.band_pass.order, std::numeric_limits<int>::min(), std::numeric_limits<int>::max());
  r.set("band_pass", b.finish());
  const json* target = r.member("target_highpass");
  if (target == nullptr || target->is_null()) {
    r.set("target_highpass", nullptr);
  } else {
    ParamReader t(*target, r.path_of("target_highpass"));
    t.number("hz", 0.0, kAnyFinite);
    t.integer("order", usecases::TargetHighpass{}.order, std::numeric_limits<int>::min(), std::numeric_limits<int>::max());
    r.set("target_highpass", t.finish());
  }
  r.integer("noise_samples", defaults.noise_samples, std::numeric_limits<long>::min(), std::numeric_limits<long>::max());
  r.integer("seed", static_cast<long long>(defaults.seed), 0, kMaxSeed);
  json filled = r.finish();
  const usecases::DesignLqRequest q = design_lq_request(filled, env, false);
  check_request([&] {
    usecases::check(q);
    q.band_pass.check("band_pass", env.fs);
  });
  return filled;
}

json design_lq_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const usecases::DesignLqRequest q = design_lq_request(params, env, true);
  usecases::DesignLqReport report = usecases::design_lq(q, progress);
  const std::string name = "lq R=" + models::number_text(report.controller.weights.R, 4) + " on " + q.plant_name + " (" +
                           control.job_id() + ")";
  const std::string model_id = store_model(env, models::lq_feedforward_to_json(report.controller), name, control);
  return {{"model_id", model_id},
          {"j_est_pct", nullptr},
          {"j_val_pct", nullptr},
          {"summary", report.summary},
          {"warnings", report.warnings},
          {"plots", {{"spectrum", report.spectrum}}}};
}

}  // namespace

JobKind design_lq_job() { return {"design-lq", design_lq_params, design_lq_work, "lq_feedforward"}; }

}  // namespace panelbass::api

#include "api/jobs/validate_job.h"

#include <string>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/record_acquisition.h"
#include "api/jobs/stored_models.h"
#include "usecases/validate_model.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

json validate_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  require_stored_model(r, "model", true, kinds_taking(models::ModelRole::plant), env);
  std::string validation_path;
  record_source(r, env, validation_path);
  r.integer("init", usecases::ValidateRequest{}.init, 0, kMaxSamples);
  return r.finish();
}

json validate_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  const JudgedPart part = judged_part(data.record);
  usecases::ValidateRequest q;
  q.model_name = params.at("model").get<std::string>();
  q.model = stored_model_file(env, q.model_name);
  q.u = part.u;
  q.y = part.y;
  q.init = params.at("init").get<long>();
  progress.span(kExcitationShare, 1.0);
  usecases::ValidateReport report;
  check_request([&] { report = usecases::validate_model(q, progress); });
  report.summary["data"] = data.source + (part.validation ? " (validation)" : " (estimation)");
  const double j = report.summary.at("J_sim_pct").get<double>();
  return {{"j_est_pct", part.validation ? json(nullptr) : json(j)},
          {"j_val_pct", part.validation ? json(j) : json(nullptr)},
          {"summary", report.summary},
          {"plots",
           {{"fit", fit_plot(q.y.tail(q.y.size() - q.init), report.y_sim.tail(q.y.size() - q.init), env.fs, q.init)},
            {"spectrum", spectrum_plot(q.u, q.y, report.y_sim, env.fs)}}}};
}

}  // namespace

JobKind validate_job() { return {"validate", validate_params, validate_work}; }

}  // namespace panelbass::api

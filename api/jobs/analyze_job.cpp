#include "api/jobs/analyze_job.h"

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/model_judgement.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/record_acquisition.h"
#include "api/jobs/stored_models.h"
#include "models/analysis/model_analysis.h"
#include "models/io/json_fields.h"
#include "models/kinds/model_file.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

json analyze_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  require_stored_model(r, "model", true, kinds_taking(models::ModelRole::plant), env);
  std::string validation_path;
  record_source(r, env, validation_path);
  return r.finish();
}

json analyze_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  const ExcitationRecord& r = data.record;
  const std::string model_id = params.at("model").get<std::string>();
  const json file = stored_model_file(env, model_id);
  const models::AnyModel model = models::model_from_json(file);
  const JudgedPart part = judged_part(r);

  models::AnalysisSpec spec;
  spec.init = init_samples(part.u.size());
  if (std::optional<models::DistortionSpec> distortion = harmonic_spec(env, model.fs(), r)) {
    spec.plant = env.plant;
    spec.distortion = std::move(*distortion);
  }
  progress.span(kExcitationShare, 0.95);
  spec.progress = [&](const std::string& stage, double f) { progress.at(f, "analysis: " + stage); };
  std::optional<models::TrainingHistory> given =
      models::training_history_from_json(json{{"meta", file.value("meta", json::object())}}, "model " + model_id);
  const models::ModelAnalysis a = models::analyze_model(model, part.u, part.y, spec, std::move(given));

  progress.span(0.95, 1.0);
  json plots = {{"fit", fit_plot(a.y, a.y_sim, env.fs, a.init)},
                {"spectrum", spectrum_plot(a.frf.frequency, a.frf.measured, a.frf.model)}};
  if (a.history) {
    std::vector<HistoryPoint> history;
    for (const auto& p : a.history->points) history.push_back({p.iteration, p.j_est_pct, p.j_val_pct});
    plots["history"] = history_plot(history);
  }
  if (a.distortion && model.kind() == "narx") plots["harmonics"] = harmonics_plot(*a.distortion);
  const double j_est = part.validation ? simulation_j(model, r.u_est, r.y_est) : a.j_sim_pct;
  const double j_val = part.validation ? a.j_sim_pct : kNaN;
  json summary = models::analysis_to_json(a);
  summary["model"] = model_id;
  summary["data"] = data.source + (part.validation ? " (validation)" : " (estimation)");
  progress.at(1.0, "done");
  return {{"j_est_pct", j_est}, {"j_val_pct", models::number_or_null(j_val)}, {"summary", summary}, {"plots", plots}};
}

}  // namespace

JobKind analyze_job() { return {"analyze", analyze_params, analyze_work}; }

}  // namespace panelbass::api

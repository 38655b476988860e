#include "api/jobs/diagnose_job.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/model_judgement.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/record_acquisition.h"
#include "api/jobs/stored_models.h"
#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/diagnosis_baselines.h"
#include "models/diagnosis/gray_box_model.h"
#include "models/kinds/model_file.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The most records at several levels a diagnosis takes ("records").
constexpr std::size_t kMaxLevelRecords = 8;

// "records": several records (ids of finished excite jobs or uploaded records, one "val_fraction" for the
// uploaded ones), each checked as "record" is; the checked list, each entry its own record params.
json level_records(ParamReader& r, const json& records, const JobEnvironment& env) {
  const std::string where = r.path_of("records");
  if (!records.is_array() || records.empty() || records.size() > kMaxLevelRecords)
    refuse(where, "must be a list of 1 to " + std::to_string(kMaxLevelRecords) +
                      " record ids (finished excite jobs \"j…\" or uploaded records \"r…\"), got " + shown(records));
  if (r.member("record") != nullptr || r.member("excite") != nullptr)
    refuse(where, "give \"records\" (several levels) or one \"record\" or \"excite\", not both");
  const json* fraction = r.member("val_fraction");
  json checked = json::array();
  for (std::size_t k = 0; k < records.size(); ++k) {
    json one = {{"record", records[k]}};
    if (fraction != nullptr) one["val_fraction"] = *fraction;
    ParamReader entry(one, where + "[" + std::to_string(k) + "]");
    std::string validation_path;
    if (record_source(entry, env, validation_path) == 0)
      refuse(validation_path, "diagnose needs validation data (it judges every augmentation on it)");
    checked.push_back(entry.finish());
  }
  return checked;
}

json diagnose_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  if (const json* records = r.member("records")) {
    r.set("records", level_records(r, *records, env));
  } else {
    std::string validation_path;
    const long long validation = record_source(r, env, validation_path);
    if (validation == 0) refuse(validation_path, "diagnose needs validation data (it judges every augmentation on it)");
  }
  require_stored_model(r, "baseline_model", false, kinds_taking(models::ModelRole::plant), env);
  r.integer("max_findings", 4, 0, 20);
  std::vector<std::string> quantities;
  for (auto q : models::all_output_quantities()) quantities.push_back(models::to_string(q));
  r.choice("sensor", "unknown", quantities);
  // The record's coil current, when it has one, as diagnose --current-col auto (docs/diagnosis.md: better on both
  // families of the detection bench); false leaves it out.
  r.boolean("use_current", true);
  return r.finish();
}

json diagnose_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  // Records at several levels: the one with the loudest drive is diagnosed, the others' validation parts judge each
  // finding at their own level.
  std::vector<SourcedRecord> levels;
  if (params.contains("records"))
    for (const json& one : params.at("records")) levels.push_back(acquire_record(one, env, progress, control));
  else
    levels.push_back(acquire_record(params, env, progress, control));
  const auto loudness = [](const SourcedRecord& s) { return s.record.u_est.squaredNorm() / std::max<double>(1.0, static_cast<double>(s.record.u_est.size())); };
  std::size_t main = 0;
  for (std::size_t k = 1; k < levels.size(); ++k)
    if (loudness(levels[k]) > loudness(levels[main])) main = k;
  const SourcedRecord& data = levels[main];
  const ExcitationRecord& r = data.record;
  // The simulation diagnosed: a stored model of any kind, or (without one) the best
  // linear OE model.
  std::optional<models::AnyModel> baseline;
  if (params.contains("baseline_model") && params.at("baseline_model").is_string()) {
    baseline = models::model_from_json(stored_model_file(env, params.at("baseline_model").get<std::string>()));
  }
  models::DiagnosisOptions options;
  options.init = kInit;
  options.max_findings = params.at("max_findings").get<int>();
  for (auto q : models::all_output_quantities())
    if (models::to_string(q) == params.value("sensor", "unknown")) options.output = q;
  if (params.value("use_current", true) && r.i_est.size() > 0)
    options.current_est = r.i_est, options.current_val = r.i_val;  // the force channel
  options.level_name = data.source;
  for (std::size_t k = 0; k < levels.size(); ++k)
    if (k != main) options.other_levels.push_back({levels[k].source, levels[k].record.u_val, levels[k].record.y_val});
  int stages = 0;
  progress.span(kExcitationShare, 0.95);
  // The diagnosis names its stages but not how many remain: each one closes part of the gap to the end.
  options.progress = [&](const std::string& stage) { progress.at(1.0 - std::pow(0.8, ++stages), "diagnose: " + stage); };
  const auto* linear = baseline ? std::get_if<models::LinearModel>(&baseline->model) : nullptr;
  const models::Diagnosis d =
      baseline && linear == nullptr
          ? models::diagnose(r.u_est, r.y_est, r.u_val, r.y_val, env.fs,
                             std::visit([&](const auto& m) { return models::model_baseline(baseline->kind(), m); }, baseline->model),
                             options)
          : models::diagnose(r.u_est, r.y_est, r.u_val, r.y_val, env.fs,
                             linear ? std::optional(*linear) : std::nullopt, options);

  progress.span(0.95, 1.0);
  json report = models::diagnosis_to_json(d);
  // The diagnosed model (a linear baseline and the terms found) is stored as a gray_box model, as diagnose
  // --model-out writes it; a baseline that is not linear has no such file.
  if (env.store != nullptr && !d.findings.empty() && !d.model.simulate_baseline)
    report["model_id"] = store_model(env, models::gray_box_model_to_json(models::gray_box_model_of(d)),
                                     "gray box (" + control.job_id() + ")", control);
  report["fs"] = env.fs;
  report["data"] = data.source;
  if (levels.size() > 1) {
    report["levels"] = json::array();
    for (std::size_t k = 0; k < levels.size(); ++k) report["levels"].push_back({{"data", levels[k].source}, {"diagnosed", k == main}});
  }
  report["j_val_pct"] = d.j_val_after_pct;
  const Eigen::Index init = init_samples(r.u_val.size());
  const Eigen::VectorXd y_sim = models::simulate_augmented(d.model, r.u_val, r.y_val, init);
  const Eigen::VectorXd y_baseline = models::simulate_augmented(d.baseline_model, r.u_val, r.y_val, init);
  const Eigen::Index n = r.u_val.size() - init;
  const Eigen::VectorXd y_judged = r.y_val.tail(n);
  report["plots"] = {{"fit", fit_plot(y_judged, y_sim.tail(n), env.fs, init)},
                     {"residual_spectrum", residual_spectrum_plot(y_judged - y_baseline.tail(n), y_judged - y_sim.tail(n),
                                                                  d.located_val.noise_psd, env.fs)}};
  progress.at(1.0, "done");
  return report;
}

}  // namespace

JobKind diagnose_job() { return {"diagnose", diagnose_params, diagnose_work, "gray_box"}; }

}  // namespace panelbass::api

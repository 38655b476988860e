#include "api/jobs/diagnose_job.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/record_acquisition.h"
#include "api/jobs/stored_models.h"
#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/diagnosis_baselines.h"
#include "models/kinds/model_file.h"
#include "usecases/diagnose.h"

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

// The request's settings of filled-in params, without its records and baseline.
usecases::DiagnoseRequest diagnose_request(const json& params) {
  usecases::DiagnoseRequest q;
  q.init = params.at("init").get<long>();
  q.scan_from = params.at("scan_from").get<int>();
  q.scan_to = params.at("scan_to").get<int>();
  q.max_findings = params.at("max_findings").get<int>();
  q.sensor = params.at("sensor").get<std::string>();
  q.use_current = params.at("use_current").get<bool>();
  return q;
}

json diagnose_params(const json& params, const JobEnvironment& env) {
  const usecases::DiagnoseRequest d;
  ParamReader r(params, "params");
  if (const json* records = r.member("records")) {
    r.set("records", level_records(r, *records, env));
  } else {
    std::string validation_path;
    const long long validation = record_source(r, env, validation_path);
    if (validation == 0) refuse(validation_path, "diagnose needs validation data (it judges every augmentation on it)");
  }
  require_stored_model(r, "baseline_model", false, kinds_taking(models::ModelRole::plant), env);
  r.integer("init", d.init, -kAnyInteger, kAnyInteger);
  r.integer("scan_from", d.scan_from, -kAnyInteger, kAnyInteger);
  r.integer("scan_to", d.scan_to, -kAnyInteger, kAnyInteger);
  r.integer("max_findings", d.max_findings, -kAnyInteger, kAnyInteger);
  r.text("sensor", d.sensor);
  // The record's coil current, when it has one, as diagnose --current-col auto; false leaves it out.
  r.boolean("use_current", d.use_current);
  json filled = r.finish();
  check_request([&] { usecases::check_settings(diagnose_request(filled)); });
  return filled;
}

json diagnose_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  // Records at several levels: the use case diagnoses the one with the loudest drive, the others' validation parts
  // judge each finding at their own level.
  std::vector<SourcedRecord> sources;
  if (params.contains("records"))
    for (const json& one : params.at("records")) sources.push_back(acquire_record(one, env, progress, control));
  else
    sources.push_back(acquire_record(params, env, progress, control));
  usecases::DiagnoseRequest q = diagnose_request(params);
  q.fs = env.fs;
  for (const SourcedRecord& s : sources)
    q.levels.push_back({s.source, s.record.u_est, s.record.y_est, s.record.u_val, s.record.y_val, s.record.i_est, s.record.i_val});
  // The simulation diagnosed: a stored model of any plant kind, or (without one) the best linear OE model.
  if (params.contains("baseline_model") && params.at("baseline_model").is_string()) {
    q.baseline_name = params.at("baseline_model").get<std::string>();
    const models::AnyModel baseline = models::model_from_json(stored_model_file(env, q.baseline_name));
    if (const auto* linear = std::get_if<models::LinearModel>(&baseline.model))
      q.linear_baseline = *linear;
    else
      q.simulation_baseline = std::visit([&](const auto& m) { return models::model_baseline(baseline.kind(), m); }, baseline.model);
  }
  progress.span(kExcitationShare, 0.95);
  usecases::DiagnoseReport result;
  check_request([&] { result = usecases::diagnose(q, progress); });
  const models::Diagnosis& d = result.diagnosis;
  const std::size_t main = result.diagnosed_level;

  progress.span(0.95, 1.0);
  json report = result.report;
  // The diagnosed model (a linear baseline and the terms found) is stored as a gray_box model, as diagnose
  // --model-out writes it; a baseline that is not linear has no such file.
  if (env.store != nullptr && !d.findings.empty() && result.model_file.is_object())
    report["model_id"] = store_model(env, result.model_file, "gray box (" + control.job_id() + ")", control);
  report["data"] = sources[main].source;
  if (sources.size() > 1) {
    report["levels"] = json::array();
    for (std::size_t k = 0; k < sources.size(); ++k) report["levels"].push_back({{"data", sources[k].source}, {"diagnosed", k == main}});
  }
  report["j_val_pct"] = d.j_val_after_pct;
  const usecases::DiagnoseLevel& r = q.levels[main];
  const Eigen::Index init = q.init;  // as the diagnosis judged it (and the CLI's figures show it)
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

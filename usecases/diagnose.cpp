#include "usecases/diagnose.h"

#include <algorithm>
#include <cmath>

#include "models/diagnosis/gray_box_model.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

// The fewest validation samples a diagnosis judges after the state-setting ones (models/diagnosis: 512).
constexpr Eigen::Index kJudgedSamples = 512;

// Throws RequestError(field, "must be within lo..hi, got v") for v outside [lo, hi].
void within(const char* field, long long v, long long lo, long long hi) {
  if (v < lo || v > hi)
    throw RequestError(field, "must be within " + std::to_string(lo) + ".." + std::to_string(hi) + ", got " + std::to_string(v));
}

// The mean square of `u` (0 for an empty one).
double mean_square(const Eigen::VectorXd& u) { return u.size() == 0 ? 0.0 : u.squaredNorm() / static_cast<double>(u.size()); }

// Refuses a level whose parts do not pair up: field "record" (each door names it its way).
void check_level(const DiagnoseLevel& level, long init) {
  const std::string which = level.name.empty() ? "the record" : level.name;
  if (level.u_est.size() != level.y_est.size() || level.u_val.size() != level.y_val.size())
    throw RequestError("record", which + ": the drive has " + std::to_string(level.u_est.size()) + " + " +
                                     std::to_string(level.u_val.size()) + " samples, the response " +
                                     std::to_string(level.y_est.size()) + " + " + std::to_string(level.y_val.size()));
  if (level.u_val.size() == 0)
    throw RequestError("record", which + ": diagnose needs validation data (it judges every augmentation on it)");
  if (level.u_val.size() < init + kJudgedSamples)
    throw RequestError("init", std::to_string(init) + " leaves fewer than " + std::to_string(kJudgedSamples) + " of the " +
                                   std::to_string(level.u_val.size()) + " validation samples to judge");
}

}  // namespace

std::vector<std::string> sensor_names() {
  std::vector<std::string> names;
  for (auto q : models::all_output_quantities()) names.push_back(models::to_string(q));
  return names;
}

void check_settings(const DiagnoseRequest& q) {
  within("init", q.init, 0, 100000000);
  within("scan_from", q.scan_from, 1, 60);
  within("scan_to", q.scan_to, 1, 60);
  if (q.scan_from > q.scan_to)
    throw RequestError("scan_from", std::to_string(q.scan_from) + " is above the highest order scanned, " + std::to_string(q.scan_to));
  within("max_findings", q.max_findings, 0, 20);
  const std::vector<std::string> names = sensor_names();
  if (std::find(names.begin(), names.end(), q.sensor) == names.end()) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    throw RequestError("sensor", "must be one of " + list + ", got \"" + q.sensor + "\"");
  }
}

void check(const DiagnoseRequest& q) {
  check_settings(q);
  if (!(std::isfinite(q.fs) && q.fs > 0.0)) throw RequestError("fs", "must be > 0 Hz, got " + std::to_string(q.fs));
  if (q.levels.empty()) throw RequestError("record", "no record to diagnose");
  for (const DiagnoseLevel& level : q.levels) check_level(level, q.init);
  const DiagnoseLevel& diagnosed = q.levels[loudest_level(q.levels)];
  if (q.use_current && (diagnosed.i_est.size() > 0) != (diagnosed.i_val.size() > 0))
    throw RequestError("use_current", (diagnosed.name.empty() ? "the record" : diagnosed.name) +
                                          ": one part has a coil current and the other none (leave the current out)");
}

nlohmann::json to_json(const DiagnoseRequest& q) {
  return {{"baseline_model", q.baseline_name}, {"init", q.init},         {"scan_from", q.scan_from},
          {"scan_to", q.scan_to},             {"max_findings", q.max_findings}, {"sensor", q.sensor},
          {"use_current", q.use_current}};
}

std::size_t loudest_level(const std::vector<DiagnoseLevel>& levels) {
  std::size_t loudest = 0;
  for (std::size_t k = 1; k < levels.size(); ++k)
    if (mean_square(levels[k].u_est) > mean_square(levels[loudest].u_est)) loudest = k;
  return loudest;
}

DiagnoseReport diagnose(const DiagnoseRequest& q, Progress& progress) {
  check(q);
  DiagnoseReport out;
  out.diagnosed_level = loudest_level(q.levels);
  const DiagnoseLevel& level = q.levels[out.diagnosed_level];
  models::DiagnosisOptions options;
  options.init = q.init;
  options.scan_from = q.scan_from;
  options.scan_to = q.scan_to;
  options.max_findings = q.max_findings;
  for (auto quantity : models::all_output_quantities())
    if (models::to_string(quantity) == q.sensor) options.output = quantity;
  if (q.use_current && level.i_est.size() > 0) {  // the force channel
    options.current_est = level.i_est;
    options.current_val = level.i_val;
  }
  options.level_name = level.name.empty() ? "validation" : level.name;
  for (std::size_t k = 0; k < q.levels.size(); ++k)
    if (k != out.diagnosed_level) options.other_levels.push_back({q.levels[k].name, q.levels[k].u_val, q.levels[k].y_val});
  int stages = 0;
  options.progress = [&](const std::string& stage) { progress.report(1.0 - std::pow(0.8, ++stages), stage); };
  progress.report(0.0, (level.name.empty() ? std::string("the record") : level.name) + ": " +
                           std::to_string(level.u_est.size()) + " + " + std::to_string(level.u_val.size()) + " samples");
  out.diagnosis = q.simulation_baseline
                      ? models::diagnose(level.u_est, level.y_est, level.u_val, level.y_val, q.fs, *q.simulation_baseline, options)
                      : models::diagnose(level.u_est, level.y_est, level.u_val, level.y_val, q.fs, q.linear_baseline, options);
  out.report = models::diagnosis_to_json(out.diagnosis);
  out.report["fs"] = q.fs;
  if (!q.baseline_name.empty()) out.report["model"] = q.baseline_name;
  if (!out.diagnosis.model.simulate_baseline)
    out.model_file = models::gray_box_model_to_json(models::gray_box_model_of(out.diagnosis));
  progress.report(1.0, "done");
  return out;
}

}  // namespace panelbass::usecases

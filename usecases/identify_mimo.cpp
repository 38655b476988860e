#include "usecases/identify_mimo.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "models/io/json_fields.h"
#include "models/io/number_text.h"
#include "models/linear/fit_warnings.h"
#include "models/linear/mimo_identification.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {

using nlohmann::json;

void check(const IdentifyMimoRequest& q) {
  const auto within = [](const char* field, long long v, long long lo, long long hi) {
    if (v < lo || v > hi) {
      throw RequestError(field, "must be within " + std::to_string(lo) + ".." + std::to_string(hi) + ", got " + std::to_string(v));
    }
  };
  if (!(q.fs > 0.0)) throw RequestError("fs", "must be a rate > 0 Hz, got " + models::number_text(q.fs));
  if (q.inputs.empty()) throw RequestError("inputs", "needs at least one input column");
  if (q.outputs.empty()) throw RequestError("outputs", "needs at least one output column");
  within("order", q.order, 0, 200);
  within("taps", q.taps, 3, 100000);
  if (!(q.ridge >= 0.0 && q.ridge <= 1.0)) throw RequestError("ridge", "must be within [0, 1], got " + models::number_text(q.ridge));
  within("max_iterations", q.max_iterations, 0, 100000);
  within("val_realizations", q.val_realizations, 0, 1000);
  if (q.records.empty()) throw RequestError("record", "needs at least one periodic record");
  if (q.record_names.size() != q.records.size()) throw RequestError("record", "each record needs its name");
  for (std::size_t i = 0; i < q.records.size(); ++i) {
    const dsp::PeriodicRecord& r = q.records[i];
    const std::string& name = q.record_names[i];
    if (r.period != q.records[0].period) {
      throw RequestError("record", name + ": periods of " + std::to_string(r.period) + " samples, the first record has " +
                                       std::to_string(q.records[0].period));
    }
    if (r.inputs != q.inputs || r.outputs != q.outputs) {
      throw RequestError("record", name + ": its columns are not the inputs and outputs asked for");
    }
    if (static_cast<std::size_t>(q.val_realizations) >= r.realizations()) {
      throw RequestError("val_realizations", name + ": " + std::to_string(r.realizations()) + " realizations; " +
                                                 std::to_string(q.val_realizations) + " held out leaves none to estimate on");
    }
  }
}

json to_json(const IdentifyMimoRequest& q) {
  return {{"record", q.record_names}, {"inputs", q.inputs},   {"outputs", q.outputs},
          {"order", q.order},         {"taps", q.taps},       {"ridge", q.ridge},
          {"max_iterations", q.max_iterations}, {"val_realizations", q.val_realizations}};
}

IdentifyMimoReport identify_mimo(const IdentifyMimoRequest& q, Progress& progress) {
  check(q);
  const auto began = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count(); };
  std::vector<Eigen::MatrixXd> u_est, y_est, u_val, y_val;
  json parts = json::array();
  for (std::size_t i = 0; i < q.records.size(); ++i) {
    const dsp::PeriodicRecord& record = q.records[i];
    const auto held = static_cast<std::size_t>(q.val_realizations);
    for (std::size_t r = 0; r < record.realizations(); ++r) {
      const bool validation = r >= record.realizations() - held;
      (validation ? u_val : u_est).push_back(record.mean_input(r));
      (validation ? y_val : y_est).push_back(record.mean_output(r));
    }
    parts.push_back({{"record", q.record_names[i]},
                     {"realizations", record.realizations()},
                     {"periods", record.periods()},
                     {"period", record.period},
                     {"held_out", held}});
  }
  models::MimoIdentificationSpec spec;
  spec.order = q.order;
  spec.taps = q.taps;
  spec.ridge = q.ridge;
  spec.max_iterations = q.max_iterations;
  json history = json::array();
  progress.report(0.0, "FIR and Kung's realisation");
  spec.progress = [&](const models::MimoRefinementRecord& r) {
    history.push_back({{"iteration", r.iteration}, {"J_est_pct", r.j_est_pct}, {"J_val_pct", r.j_val_pct}});
    progress.report(static_cast<double>(r.iteration) / std::max(1, q.max_iterations),
                    "iteration " + std::to_string(r.iteration) + ": J_est " + models::number_text(r.j_est_pct) + " %");
    return !progress.stopping();
  };
  const models::MimoIdentification id = models::identify_mimo(u_est, y_est, u_val, y_val, spec);

  IdentifyMimoReport report;
  report.model.ss = id.model;
  report.model.fs = q.fs;
  report.model.inputs = q.inputs;
  report.model.outputs = q.outputs;
  report.model.meta = {{"method", "fir-kung-oe"},
                       {"data", q.record_names},
                       {"taps", q.taps},
                       {"ridge", q.ridge},
                       {"val_realizations", q.val_realizations},
                       {"J_est_pct", id.refinement.j_est_pct},
                       {"J_val_pct", id.refinement.j_val_pct},
                       {"kung_J_val_pct", id.kung_j_val_pct},
                       {"best_iteration", id.refinement.best_iteration}};
  const Eigen::Index shown = std::min<Eigen::Index>(id.hankel_singular_values.size(), 60);
  report.summary = {{"order", id.order},
                    {"inputs", q.inputs.size()},
                    {"outputs", q.outputs.size()},
                    {"records", parts},
                    {"J_est_pct", id.refinement.j_est_pct},
                    {"J_val_pct", id.refinement.j_val_pct},
                    {"kung_J_est_pct", id.kung_j_est_pct},
                    {"kung_J_val_pct", id.kung_j_val_pct},
                    {"iterations", id.refinement.iterations},
                    {"best_iteration", id.refinement.best_iteration},
                    {"hankel_singular_values", models::to_array(id.hankel_singular_values.head(shown))},
                    {"history", history},
                    {"seconds", seconds()}};
  report.warnings = models::fit_warnings(u_val.empty() ? id.refinement.j_est_pct : id.refinement.j_val_pct,
                                         u_val.empty() ? "J_est" : "J_val", NAN,
                                         "Try another order, more taps, or more iterations.");
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases

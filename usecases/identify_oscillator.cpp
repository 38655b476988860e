#include "usecases/identify_oscillator.h"

#include <cstdio>

#include "models/io/json_fields.h"
#include "models/linear/fit_warnings.h"
#include "models/oscillator/oscillator_fit.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

// The structure of the request's terms, taps and substeps (RequestError naming the field).
models::OscillatorStructure structure_of(const IdentifyOscillatorRequest& q) {
  models::OscillatorStructure s;
  for (const std::string& name : q.terms) {
    try {
      s.terms.push_back(models::oscillator_term_from_name(name));
    } catch (const std::invalid_argument& e) {
      throw RequestError("terms", e.what());
    }
  }
  s.substeps = q.substeps;
  s.output_taps = q.output_taps;
  s.input_taps = q.input_taps;
  try {
    s.check();
  } catch (const std::invalid_argument& e) {
    throw RequestError("terms", e.what());
  }
  return s;
}

}  // namespace

void check(const IdentifyOscillatorRequest& q) {
  const auto within = [](const char* field, long v, long lo, long hi) {
    if (v < lo || v > hi) {
      throw RequestError(field, "must be within " + std::to_string(lo) + ".." + std::to_string(hi) + ", got " + std::to_string(v));
    }
  };
  within("substeps", q.substeps, 1, 64);
  within("output_taps", q.output_taps, 0, 64);
  within("input_taps", q.input_taps, 0, 64);
  within("max_iterations", q.max_iterations, 1, 100000);
  within("init", q.init, 0, 100000000);
  (void)structure_of(q);
  if (q.u_est.size() != q.y_est.size() || q.u_val.size() != q.y_val.size()) {
    throw RequestError("record", "a part's drive and response differ in length");
  }
}

nlohmann::json to_json(const IdentifyOscillatorRequest& q) {
  return {{"record", q.data_name},          {"val", q.val_name},   {"terms", q.terms},
          {"substeps", q.substeps},         {"output_taps", q.output_taps}, {"input_taps", q.input_taps},
          {"max_iterations", q.max_iterations}, {"init", q.init}, {"delay", q.delay}};
}

IdentifyOscillatorReport identify_oscillator(const IdentifyOscillatorRequest& q, Progress& progress) {
  check(q);
  models::OscillatorFitOptions options;
  options.structure = structure_of(q);
  options.delay = q.delay;
  options.max_iterations = q.max_iterations;
  options.init = q.init;
  options.progress = [&](const models::OscillatorFitProgress& p) {
    progress.report((static_cast<double>(p.stage_number) + static_cast<double>(p.iteration) / q.max_iterations) /
                        static_cast<double>(p.stages),
                    "stage " + p.stage + ", iteration " + std::to_string(p.iteration));
    return !progress.stopping();
  };
  models::OscillatorFit fit = models::fit_oscillator(q.u_est, q.y_est, q.u_val, q.y_val, q.fs, options);
  nlohmann::json stages = nlohmann::json::array();
  for (const models::OscillatorStage& s : fit.stages) {
    stages.push_back({{"stage", s.name},
                      {"iterations", s.iterations},
                      {"J_est_pct", models::number_or_null(s.j_est_pct)},
                      {"J_val_pct", models::number_or_null(s.j_val_pct)},
                      {"seconds", s.seconds}});
  }
  const models::OscillatorStage& best = fit.stages[fit.best_stage];
  // A fit worse than a linear model of its own order (2) on the same part says so (fit_warnings).
  const bool validated = q.u_val.size() > 0;
  const double j_linear = models::linear_reference_j_pct(q.u_est, q.y_est, q.u_val, q.y_val, 2, 0, q.init);
  const std::string advice =
      "The record may not be one mass on a spring (more resonances, a coil's inductance, a sensor that "
      "differentiates): try identify linear, narx or ss, or more terms and output/input taps.";
  IdentifyOscillatorReport report;
  report.warnings = models::fit_warnings(validated ? best.j_val_pct : best.j_est_pct, validated ? "J_val" : "J_est",
                                         j_linear, advice);
  const double j_judged = validated ? best.j_val_pct : best.j_est_pct;
  if (report.warnings.empty() && j_judged > kUsefulOscillatorJPct) {
    char figure[64];
    std::snprintf(figure, sizeof figure, "%.3g", j_judged);
    report.warnings.push_back(std::string(validated ? "J_val" : "J_est") + " = " + figure +
                              " %: the oscillator misses more than a tenth of the output's energy. " + advice);
  }
  fit.model.meta = {{"data", q.data_name},
                    {"val", q.val_name},
                    {"init", q.init},
                    {"J_est_pct", models::number_or_null(best.j_est_pct)},
                    {"J_val_pct", models::number_or_null(best.j_val_pct)},
                    {"chosen_stage", best.name},
                    {"stages", stages},
                    {"seconds", fit.stages.back().seconds}};
  report.summary = {{"J_est_pct", models::number_or_null(best.j_est_pct)},
                    {"J_val_pct", models::number_or_null(best.j_val_pct)},
                    {"chosen_stage", best.name},
                    {"stages", stages},
                    {"params", fit.model.theta.size()},
                    {"seconds", fit.stages.back().seconds}};
  report.model = std::move(fit.model);
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases

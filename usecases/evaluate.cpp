#include "usecases/evaluate.h"

#include <algorithm>

#include "evaluation/evaluation_json.h"
#include "models/plant/plant_presets.h"
#include "models/io/number_text.h"
#include "usecases/request_checks.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

// The plant of the request: its own, or the preset it names.
models::PlantConfig plant_of(const EvaluateRequest& q) { return q.plant_config ? *q.plant_config : models::plant_preset(q.plant); }

}  // namespace

void check(const EvaluateRequest& q) {
  if (!q.plant_config) {
    const std::vector<std::string> presets = models::plant_preset_names();
    if (std::find(presets.begin(), presets.end(), q.plant) == presets.end()) {
      std::string names;
      for (const std::string& p : presets) names += (names.empty() ? "" : ", ") + p;
      throw RequestError("plant", "must be a preset (" + names + ") or a plant file, got \"" + q.plant + "\"");
    }
  }
  within("probes_hz", static_cast<long long>(q.probes_hz.size()), 1, 16);
  for (const double f : q.probes_hz) {
    if (!(f > 0.0 && f < q.chain.fs / 2.0)) {
      throw RequestError("probes_hz", "each must be within (0, " + models::number_text(q.chain.fs / 2.0) + ") Hz, got " +
                                          models::number_text(f));
    }
  }
  within_real("probe_peak", q.probe_peak, 0.0, 1.0);
  within("noise_samples", q.noise_samples, 4096, 100000000);
  within("levels", static_cast<long long>(q.levels.size()), 1, 32);
  for (const double a : q.levels) {
    if (!(a > 0.0 && a <= 1.0)) throw RequestError("levels", "each must be within (0, 1], got " + models::number_text(a));
  }
}

nlohmann::json to_json(const EvaluateRequest& q) {
  // The chain by the door's own fields (a file; the stored models it is built of), not here.
  return {{"plant", q.plant},       {"probes_hz", q.probes_hz},
          {"probe_peak", q.probe_peak},    {"noise_samples", q.noise_samples}, {"seed", q.seed},
          {"attribute", q.attribute},      {"level_sweep", q.level_sweep},     {"levels", q.levels}};
}

EvaluateReport evaluate(const EvaluateRequest& q, Progress& progress) {
  check(q);
  const models::PlantConfig plant = plant_of(q);
  evaluation::EvaluationOptions options;
  options.probe_hz = q.probes_hz;
  options.probe_peak = q.probe_peak;
  options.noise_samples = q.noise_samples;
  options.seed = q.seed;
  // The J_c table needs an LQ feedforward stage (its desired response is the J_c reference); a chain whose
  // feedforward is a mirror filter is judged by the level sweep.
  const bool lq = !(q.chain.feedforward && q.chain.feedforward->model.value("kind", "") == "mirror_filter");
  EvaluateReport report;
  report.summary = {{"plant", plant.name},
                    {"chain", q.chain_name},
                    {"noise_amplitude", 0.0},
                    {"jc_noise_floor_pct", 0.0},
                    {"probe_peak", q.probe_peak},
                    {"probes_hz", q.probes_hz},
                    {"ripple_band_hz", {options.ripple_low_hz, options.ripple_high_hz}},
                    {"rows", nlohmann::json::array()}};
  if (lq) {
    progress.report(0.05, "evaluating the chain on " + plant.name);
    report.evaluation = evaluation::evaluate_chain(q.chain, plant, options);
    report.summary["noise_amplitude"] = report.evaluation->noise_amplitude;
    report.summary["jc_noise_floor_pct"] = report.evaluation->jc_noise_floor_pct;
    for (const evaluation::EvaluationRow& row : report.evaluation->rows) {
      report.summary["rows"].push_back(evaluation::evaluation_row_to_json(row));
    }
  }
  const bool sweeping = q.level_sweep || !lq;
  if (q.attribute && lq) {
    ProgressSpan span(progress, 0.4, sweeping ? 0.7 : 1.0);
    report.attribution = evaluation::attribute_distortion(
        q.chain, plant, options, [&](std::size_t done, std::size_t total, const std::string& term) {
          span.report(static_cast<double>(done) / static_cast<double>(total), "evaluating with only the " + term + " on");
        });
    report.summary["attribution"] = evaluation::attribution_to_json(report.attribution);
  }
  if (sweeping) {
    // THD against the output level (the chain beside the plant alone at equal sensor fundamental) and two-tone IMD.
    ProgressSpan span(progress, q.attribute && lq ? 0.7 : 0.4, 1.0);
    evaluation::LevelSweepOptions sweep;
    sweep.frequencies_hz = q.probes_hz;
    sweep.program_amplitudes = q.levels;
    sweep.seed = q.seed;
    report.sweep = evaluation::sweep_levels(q.chain, plant, sweep, [&](std::size_t done, std::size_t total) {
      span.report(static_cast<double>(done) / static_cast<double>(total), "THD against output level");
    });
    report.summary["level_sweep"] = evaluation::level_sweep_to_json(*report.sweep);
  }
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases

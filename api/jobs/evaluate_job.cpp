#include "api/jobs/evaluate_job.h"

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/lq_band_pass.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/excitation_record.h"
#include "api/jobs/stored_models.h"
#include "evaluation/chain_evaluation.h"
#include "engine/chain_file.h"
#include "evaluation/distortion_attribution.h"
#include "evaluation/level_sweep.h"
#include "evaluation/evaluation_json.h"
#include "models/control/lq_feedforward.h"
#include "models/plant/plant_presets.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// A chain of stored controllers evaluated on a virtual transducer (panelbass evaluate).
json evaluate_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  require_stored_model(r, "feedforward_model", true, {"lq_feedforward"}, env);
  require_stored_model(r, "feedback_model", false, {"neural_feedback"}, env);
  const std::string source = r.choice("source", "model", {"model", "sensor"});
  const json* feedback = r.member("feedback_model");
  if (source == "sensor" && (feedback == nullptr || feedback->is_null())) {
    refuse(r.path_of("source"), "\"sensor\" is where a feedback stage takes its past outputs from, and there is no feedback_model");
  }
  // The server's own virtual transducer when it runs one, or a preset.
  std::vector<std::string> plants = models::plant_preset_names();
  if (env.plant) plants.insert(plants.begin(), "server");
  r.choice("plant", plants.front(), plants);
  const evaluation::EvaluationOptions defaults;
  r.numbers("probes_hz", defaults.probe_hz, 1, 16, {0.0, env.fs / 2.0, true, true});
  r.number("probe_peak", defaults.probe_peak, {0.0, 1.0, false, false});
  r.integer("noise_samples", defaults.noise_samples, 4096, kMaxSamples);
  r.integer("seed", 1, 0, kMaxSeed);
  r.boolean("attribute", false);
  r.boolean("level_sweep", false);
  return r.finish();
}

// The plot columns' prefix for evaluation row `row` (plant, band-pass + feedforward, + feedback).
const char* evaluation_row_key(std::size_t row) {
  static const char* const kKeys[] = {"plant", "feedforward", "feedback"};
  return row < 3 ? kKeys[row] : "row";
}

// A chain of stored controllers (the feedforward's band-pass, the LQ feedforward, the neural feedback if any)
// evaluated on a virtual transducer, as panelbass chain + evaluate [--attribute].
json evaluate_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const std::string ff_id = params.at("feedforward_model").get<std::string>();
  const json fb_param = params.value("feedback_model", json(nullptr));  // absent or null: no feedback stage
  const std::string fb_id = fb_param.is_string() ? fb_param.get<std::string>() : "";
  progress.at(0.0, "reading " + ff_id + (fb_id.empty() ? "" : " and " + fb_id));
  engine::ChainConfig config;
  config.fs = env.fs;
  config.feedforward = engine::SlotConfig{};
  config.feedforward->model = stored_model_file(env, ff_id);
  const LqBandPass band = lq_band_pass(models::lq_feedforward_from_json(config.feedforward->model));
  const double lo = band.low_hz, hi = band.high_hz;
  const int band_order = band.order;
  config.band_pass.design = {engine::Hertz{lo}, engine::Hertz{hi}, band_order};
  if (!fb_id.empty()) {
    config.feedback = engine::SlotConfig{};
    config.feedback->model = stored_model_file(env, fb_id);
    config.feedback->source =
        params.at("source").get<std::string>() == "sensor" ? engine::FeedbackSource::sensor : engine::FeedbackSource::model;
  }
  const std::string plant_name = params.at("plant").get<std::string>();
  const models::PlantConfig plant = plant_name == "server" ? *env.plant : models::plant_preset(plant_name);
  evaluation::EvaluationOptions options;
  options.probe_hz = params.at("probes_hz").get<std::vector<double>>();
  options.probe_peak = params.at("probe_peak").get<double>();
  options.noise_samples = params.at("noise_samples").get<Eigen::Index>();
  options.seed = params.at("seed").get<std::uint64_t>();
  const bool attribute = params.at("attribute").get<bool>();

  progress.at(0.05, "evaluating the chain on " + plant.name);
  const evaluation::ChainEvaluation e = evaluation::evaluate_chain(config, plant, options);
  json rows = json::array();
  for (const evaluation::EvaluationRow& row : e.rows) rows.push_back(evaluation::evaluation_row_to_json(row));
  // The table at a glance: each row's ripple, J_c and THD per probe.
  json table = json::object();
  json response = {{"f", column(e.rows.front().response_hz)}};
  json thd = {{"f", options.probe_hz}};
  for (std::size_t k = 0; k < e.rows.size(); ++k) {
    const evaluation::EvaluationRow& row = e.rows[k];
    json row_thd = json::array();
    for (const evaluation::ProbeResult& p : row.probes) row_thd.push_back(p.thd_pct);
    table[row.name] = {{"ripple_db", row.ripple_db},
                       {"jc_pct", row.jc_pct},
                       {"measured_ripple_db", row.measured_ripple_db},
                       {"measured_jc_pct", row.measured_jc_pct},
                       {"thd_pct", row_thd},
                       {"max_drive", row.max_drive}};
    response[std::string(evaluation_row_key(k)) + "_db"] = column(row.response_db);
    thd[std::string(evaluation_row_key(k)) + "_thd_pct"] = row_thd;
  }
  json summary = {{"plant", plant.name},
                  {"feedforward_model", ff_id},
                  {"feedback_model", fb_id.empty() ? json(nullptr) : json(fb_id)},
                  {"source", fb_id.empty() ? json(nullptr) : params.at("source")},
                  {"bandpass", {lo, hi}},
                  {"bandpass_order", band_order},
                  {"probes_hz", options.probe_hz},
                  {"probe_peak", options.probe_peak},
                  {"noise_amplitude", e.noise_amplitude},
                  {"jc_noise_floor_pct", e.jc_noise_floor_pct},
                  {"table", table}};
  json result = {{"summary", summary}, {"rows", rows}, {"plots", {{"response", response}, {"thd", thd}}}};
  if (attribute) {
    progress.span(0.5, 1.0);
    const std::vector<evaluation::TermDistortion> terms = evaluation::attribute_distortion(
        config, plant, options, [&](std::size_t done, std::size_t total, const std::string& term) {
          progress.at(static_cast<double>(done) / static_cast<double>(total), "evaluating with only the " + term + " on");
        });
    // Each term's THD per probe behind band-pass + feedforward: what a feedback stage is there to remove.
    json by_term = json::object();
    for (const evaluation::TermDistortion& t : terms) {
      json term_thd = json::array();
      for (const evaluation::ProbeResult& p : t.rows.at(1).probes) term_thd.push_back(p.thd_pct);
      by_term[t.term] = term_thd;
    }
    result["summary"]["attribution_thd_pct"] = by_term;
    result["attribution"] = evaluation::attribution_to_json(terms);
  }
  if (params.at("level_sweep").get<bool>()) {
    // THD against the output level (the chain beside the plant alone at equal sensor fundamental) and two-tone IMD,
    // as evaluate --level-sweep; the chart's curves in "plots": per probe, output level and THD of each.
    progress.span(attribute ? 0.9 : 0.5, 1.0);
    evaluation::LevelSweepOptions sweep_options;
    sweep_options.frequencies_hz = options.probe_hz;
    sweep_options.seed = options.seed;
    const evaluation::LevelSweep sweep =
        evaluation::sweep_levels(config, plant, sweep_options, [&](std::size_t done, std::size_t total) {
          progress.at(static_cast<double>(done) / static_cast<double>(total), "THD against output level");
        });
    result["level_sweep"] = evaluation::level_sweep_to_json(sweep);
    // where the program needs more drive than the chain can give: per probe, the program amplitudes whose drive
    // asked for full scale or more (the web shows them as a warning)
    json needs = json::object();
    for (const evaluation::LevelCurve& c : sweep.curves) {
      json levels = json::array();
      for (const evaluation::LevelPoint& p : c.points) {
        if (p.needs_more_drive) levels.push_back(p.program_amplitude);
      }
      if (!levels.empty()) needs[std::to_string(static_cast<int>(std::lround(c.frequency_hz))) + " Hz"] = levels;
    }
    result["summary"]["needs_more_drive"] = needs.empty() ? json(false) : needs;
    // one plot per probe, its columns equally long: the levels the chain reached, THD of each there
    for (const evaluation::LevelCurve& c : sweep.curves) {
      json chain_level = json::array(), chain_thd = json::array(), plant_thd = json::array();
      for (const evaluation::LevelPoint& p : c.points) {
        if (!p.reachable) continue;
        chain_level.push_back(p.chain.fundamental);
        chain_thd.push_back(p.chain.thd_pct);
        plant_thd.push_back(p.plant.thd_pct);
      }
      result["plots"]["thd_vs_level_" + std::to_string(static_cast<int>(std::lround(c.frequency_hz)))] =
          json{{"level", chain_level}, {"chain_thd_pct", chain_thd}, {"plant_thd_pct", plant_thd}};
    }
  }
  progress.at(1.0, "done");
  return result;
}

}  // namespace

JobKind evaluate_job() { return {"evaluate", evaluate_params, evaluate_work}; }

}  // namespace panelbass::api

#include "api/jobs/evaluate_job.h"

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/lq_band_pass.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/stored_models.h"
#include "engine/chain_file.h"
#include "models/control/lq_feedforward.h"
#include "models/plant/plant_presets.h"
#include "usecases/evaluate.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The request of filled-in params, without its chain and plant.
usecases::EvaluateRequest evaluate_request(const json& params, double fs) {
  usecases::EvaluateRequest q;
  q.chain.fs = fs;
  q.plant = params.at("plant").get<std::string>();
  q.probes_hz = params.at("probes_hz").get<std::vector<double>>();
  q.probe_peak = params.at("probe_peak").get<double>();
  q.noise_samples = params.at("noise_samples").get<long>();
  q.seed = params.at("seed").get<std::uint64_t>();
  q.attribute = params.at("attribute").get<bool>();
  q.level_sweep = params.at("level_sweep").get<bool>();
  q.levels = params.at("levels").get<std::vector<double>>();
  return q;
}

// A chain of stored controllers evaluated on a virtual transducer (panelbass evaluate).
json evaluate_params(const json& params, const JobEnvironment& env) {
  const usecases::EvaluateRequest d;
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
  r.choice("plant", env.plant ? "server" : d.plant, plants);
  r.numbers("probes_hz", d.probes_hz, 0, 64, kAnyFinite);
  r.number("probe_peak", d.probe_peak, kAnyFinite);
  r.integer("noise_samples", d.noise_samples, -kAnyInteger, kAnyInteger);
  r.integer("seed", static_cast<long long>(d.seed), 0, kMaxSeed);
  r.boolean("attribute", d.attribute);
  r.boolean("level_sweep", d.level_sweep);
  r.numbers("levels", d.levels, 0, 64, kAnyFinite);
  json filled = r.finish();
  usecases::EvaluateRequest q = evaluate_request(filled, env.fs);
  if (q.plant == "server") q.plant_config = env.plant;
  check_request([&] { usecases::check(q); });
  return filled;
}

// The plot columns' prefix for evaluation row `row` (plant, band-pass + feedforward, + feedback).
const char* evaluation_row_key(std::size_t row) {
  static const char* const kKeys[] = {"plant", "feedforward", "feedback"};
  return row < 3 ? kKeys[row] : "row";
}

// A chain of stored controllers (the feedforward's band-pass, the LQ feedforward, the neural feedback if any)
// evaluated on a virtual transducer, as panelbass chain + evaluate [--attribute] [--level-sweep].
json evaluate_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const std::string ff_id = params.at("feedforward_model").get<std::string>();
  const json fb_param = params.value("feedback_model", json(nullptr));  // absent or null: no feedback stage
  const std::string fb_id = fb_param.is_string() ? fb_param.get<std::string>() : "";
  progress.at(0.0, "reading " + ff_id + (fb_id.empty() ? "" : " and " + fb_id));
  usecases::EvaluateRequest q = evaluate_request(params, env.fs);
  engine::ChainConfig& config = q.chain;
  config.feedforward = engine::SlotConfig{};
  config.feedforward->model = stored_model_file(env, ff_id);
  const LqBandPass band = lq_band_pass(models::lq_feedforward_from_json(config.feedforward->model));
  config.band_pass.design = {engine::Hertz{band.low_hz}, engine::Hertz{band.high_hz}, band.order};
  if (!fb_id.empty()) {
    config.feedback = engine::SlotConfig{};
    config.feedback->model = stored_model_file(env, fb_id);
    config.feedback->source =
        params.at("source").get<std::string>() == "sensor" ? engine::FeedbackSource::sensor : engine::FeedbackSource::model;
  }
  q.chain_name = fb_id.empty() ? ff_id : ff_id + " + " + fb_id;
  if (q.plant == "server") q.plant_config = env.plant;
  usecases::EvaluateReport report;
  check_request([&] { report = usecases::evaluate(q, progress); });
  const evaluation::ChainEvaluation& e = *report.evaluation;  // an lq_feedforward chain: always a table

  json rows = report.summary.at("rows");
  // The table at a glance: each row's ripple, J_c and THD per probe.
  json table = json::object();
  json response = {{"f", column(e.rows.front().response_hz)}};
  json thd = {{"f", q.probes_hz}};
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
  json summary = {{"plant", report.summary.at("plant")},
                  {"feedforward_model", ff_id},
                  {"feedback_model", fb_id.empty() ? json(nullptr) : json(fb_id)},
                  {"source", fb_id.empty() ? json(nullptr) : params.at("source")},
                  {"bandpass", {band.low_hz, band.high_hz}},
                  {"bandpass_order", band.order},
                  {"probes_hz", q.probes_hz},
                  {"probe_peak", q.probe_peak},
                  {"noise_amplitude", e.noise_amplitude},
                  {"jc_noise_floor_pct", e.jc_noise_floor_pct},
                  {"table", table}};
  json result = {{"summary", summary}, {"rows", rows}, {"plots", {{"response", response}, {"thd", thd}}}};
  if (q.attribute) {
    // Each term's THD per probe behind band-pass + feedforward: what a feedback stage is there to remove.
    json by_term = json::object();
    for (const evaluation::TermDistortion& t : report.attribution) {
      json term_thd = json::array();
      for (const evaluation::ProbeResult& p : t.rows.at(1).probes) term_thd.push_back(p.thd_pct);
      by_term[t.term] = term_thd;
    }
    result["summary"]["attribution_thd_pct"] = by_term;
    result["attribution"] = report.summary.at("attribution");
  }
  if (report.sweep) {
    // The chart's curves in "plots": per probe, output level and THD of each.
    const evaluation::LevelSweep& sweep = *report.sweep;
    result["level_sweep"] = report.summary.at("level_sweep");
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
  return result;
}

}  // namespace

JobKind evaluate_job() { return {"evaluate", evaluate_params, evaluate_work}; }

}  // namespace panelbass::api

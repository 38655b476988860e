#include "api/jobs/design_nn_job.h"

#include <limits>
#include <string>
#include <vector>

#include "api/jobs/hidden_layers.h"
#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/stored_models.h"
#include "models/control/model_probes.h"
#include "models/io/json_fields.h"
#include "models/plant/plant_presets.h"
#include "usecases/design_nn.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The request of filled-in params; the model files read from the store when `with_models` (the params check has
// only their ids), the device tuned on from the server's own virtual transducer ("server") or a preset.
usecases::DesignNnRequest design_nn_request(const json& p, const JobEnvironment& env, bool with_models) {
  usecases::DesignNnRequest q;
  q.plant_name = p.at("plant_model").get<std::string>();
  q.feedforward_name = p.at("feedforward_model").get<std::string>();
  if (with_models) {
    q.plant_model = stored_model_file(env, q.plant_name);
    q.feedforward_model = stored_model_file(env, q.feedforward_name);
  }
  if (const json& band = p.at("band_pass"); !band.is_null()) {
    q.band_pass = usecases::BandPass{band.at("low_hz").get<double>(), band.at("high_hz").get<double>(), band.at("order").get<int>()};
  }
  models::FeedbackDesignOptions& d = q.design;
  d.samples = p.at("samples").get<Eigen::Index>();
  d.training.max_iterations = p.at("max_iterations").get<int>();
  d.structure.hidden = hidden_widths(p.at("hidden"));
  d.structure.nu = p.at("nu").get<int>();
  d.structure.nv = p.at("nv").get<int>();
  d.structure.ny = p.at("ny").get<int>();
  d.sine_share = p.at("sine_share").get<double>();
  d.sine_peak = p.at("sine_peak").get<double>();
  d.sine_low_hz = p.at("sine_band").at(0).get<double>();
  d.sine_high_hz = p.at("sine_band").at(1).get<double>();
  d.program_share = p.at("program_share").get<double>();
  d.desired = models::desired_response_from_name(p.at("desired").get<std::string>());
  const std::string weighting = p.at("weighting").get<std::string>();
  d.level_weighting = weighting == "level";
  d.distortion_weighting = weighting == "distortion";
  d.restarts = p.at("restarts").get<int>();
  d.keep = models::restart_choice_from_name(p.at("keep").get<std::string>());
  d.probe_hz = p.at("probes_hz").get<std::vector<double>>();
  d.training.rail_penalty = p.at("rail_penalty").get<double>();
  d.training.dc_penalty = p.at("dc_penalty").get<double>();
  d.seed = p.at("seed").get<std::uint64_t>();
  d.device_playbacks = p.at("tune_playbacks").get<int>();
  const std::string tune_on = p.at("tune_on").get<std::string>();
  if (tune_on != "none") q.tune_on = tune_on == "server" ? *env.plant : models::plant_preset(tune_on);
  if (const json start = p.value("start_from", json(nullptr)); start.is_string()) {
    q.start_from = start.get<std::string>();
    if (with_models) q.start_from_model = stored_model_file(env, q.start_from);
  }
  return q;
}

json design_nn_params(const json& params, const JobEnvironment& env) {
  const usecases::DesignNnRequest defaults;
  const models::FeedbackDesignOptions& design = defaults.design;
  ParamReader r(params, "params");
  require_stored_model(r, "plant_model", true, {"narx", "ss"}, env);
  require_stored_model(r, "feedforward_model", true, {"lq_feedforward"}, env);
  const json* band = r.member("band_pass");
  if (band == nullptr || band->is_null()) {
    r.set("band_pass", nullptr);  // the feedforward's own
  } else {
    const usecases::BandPass b0;
    ParamReader b(*band, r.path_of("band_pass"));
    b.number("low_hz", b0.low_hz, kAnyFinite);
    b.number("high_hz", b0.high_hz, kAnyFinite);
    b.integer("order", b0.order, std::numeric_limits<int>::min(), std::numeric_limits<int>::max());
    r.set("band_pass", b.finish());
  }
  r.integer("samples", design.samples, 1000, kMaxSamples);
  r.integer("max_iterations", design.training.max_iterations, 0, kMaxIterations);
  hidden_layers(r, std::vector<long long>(design.structure.hidden.begin(), design.structure.hidden.end()));
  r.integer("nu", design.structure.nu, 0, usecases::kMaxControllerLag);
  r.integer("nv", design.structure.nv, 0, usecases::kMaxControllerLag);
  r.integer("ny", design.structure.ny, 0, usecases::kMaxControllerLag);
  r.number("sine_share", design.sine_share, {0.0, 1.0, false, false});
  r.number("sine_peak", design.sine_peak, {0.0, 1.0, true, false});
  r.numbers("sine_band", {design.sine_low_hz, design.sine_high_hz}, 2, 2, {0.0, env.fs / 2.0, true, true});
  r.number("program_share", design.program_share, {0.0, 1.0, false, false});
  r.choice("desired", models::desired_response_name(design.desired),
           {"linear-model", "plant-small-signal", "plant-fundamental"});
  r.choice("weighting", "none", {"none", "level", "distortion"});
  r.integer("restarts", design.restarts, 1, usecases::kMaxFeedbackRestarts);
  r.choice("keep", models::restart_choice_name(design.keep), {"validation-jc", "worst-probe"});
  r.numbers("probes_hz", models::evaluation_probe_hz(), 1, 16, {0.0, env.fs / 4.0, true, true});
  r.number("rail_penalty", design.training.rail_penalty, {0.0, usecases::kMaxFeedbackPenalty, false, false});
  r.number("dc_penalty", design.training.dc_penalty, {0.0, usecases::kMaxFeedbackPenalty, false, false});
  r.integer("seed", static_cast<long long>(design.seed), 0, kMaxSeed);
  // Tuning on a device (panelbass design nn --tune-on): the server's own virtual transducer when it runs one,
  // or a preset; "none": the plant model alone. Training on from a stored controller (--start-from).
  std::vector<std::string> devices = models::plant_preset_names();
  if (env.plant) devices.insert(devices.begin(), "server");
  devices.insert(devices.begin(), "none");
  r.choice("tune_on", "none", devices);
  r.integer("tune_playbacks", design.device_playbacks, 1, usecases::kMaxDevicePlaybacks);
  require_stored_model(r, "start_from", false, {"neural_feedback"}, env);
  json filled = r.finish();
  check_request([&] {
    const usecases::DesignNnRequest q = design_nn_request(filled, env, false);
    usecases::check(q);
    if (q.band_pass) q.band_pass->check("band_pass", env.fs);
  });
  return filled;
}

json design_nn_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const usecases::DesignNnRequest q = design_nn_request(params, env, true);
  usecases::DesignNnReport report;
  check_request([&] { report = usecases::design_nn(q, progress); });
  const std::string name = "nn " + hidden_text(report.controller.structure.hidden) + " on " + q.plant_name + " (" +
                           control.job_id() + ")";
  const std::string model_id = store_model(env, models::neural_feedback_to_json(report.controller), name, control);
  std::vector<HistoryPoint> history;
  for (const models::FeedbackTrainingRecord& rec : report.training.history) {
    history.push_back({rec.iteration, rec.jc_est_pct, rec.jc_val_pct});
  }
  return {{"model_id", model_id},
          {"j_est_pct", models::number_or_null(report.jc_est_pct)},
          {"j_val_pct", report.summary.at("jc_val_after_pct")},
          {"summary", report.summary},
          {"plots", {{"history", history_plot(history)}}}};
}

}  // namespace

JobKind design_nn_job() { return {"design-nn", design_nn_params, design_nn_work, "neural_feedback"}; }

}  // namespace panelbass::api

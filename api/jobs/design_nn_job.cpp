#include "api/jobs/design_nn_job.h"

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "api/jobs/hidden_layers.h"
#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/lq_band_pass.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/excitation_record.h"
#include "api/jobs/stored_models.h"
#include "models/control/feedback_design.h"
#include "models/control/loop_plant.h"
#include "models/control/lq_feedforward.h"
#include "models/control/model_probes.h"
#include "models/control/neural_feedback.h"
#include "models/io/json_fields.h"
#include "models/io/number_text.h"
#include "models/plant/plant_presets.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The NN feedback controller's input lags and rail penalty, as far as `panelbass design nn` takes them.
constexpr long long kMaxControllerLag = 100;
constexpr double kMaxRailPenalty = 1e12;
// Trainings from fresh initial weights in one design-nn job (each costs as much as the whole training).
constexpr long long kMaxRestarts = 20;
// Playbacks of each drive into the device a design-nn job tunes on (each costs a simulation of the record).
constexpr long long kMaxPlaybacks = 64;

json design_nn_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  require_stored_model(r, "plant_model", true, {"narx", "ss"}, env);
  require_stored_model(r, "feedforward_model", true, {"lq_feedforward"}, env);
  const models::FeedbackDesignOptions design;
  r.integer("samples", 3000, 1000, kMaxSamples);
  r.integer("max_iterations", 20, 0, kMaxIterations);
  hidden_layers(r, {6});
  r.integer("nu", design.structure.nu, 0, kMaxControllerLag);
  r.integer("nv", design.structure.nv, 0, kMaxControllerLag);
  r.integer("ny", design.structure.ny, 0, kMaxControllerLag);
  r.number("sine_share", design.sine_share, {0.0, 1.0, false, false});
  r.number("sine_peak", design.sine_peak, {0.0, 1.0, true, false});
  r.number("program_share", design.program_share, {0.0, 1.0, false, false});
  const std::string desired = r.choice("desired", models::desired_response_name(design.desired),
                                      {"linear-model", "plant-small-signal", "plant-fundamental"});
  const std::string weighting = r.choice("weighting", "none", {"none", "level", "distortion"});
  const long long restarts = r.integer("restarts", design.restarts, 1, kMaxRestarts);
  r.choice("keep", models::restart_choice_name(design.keep), {"validation-jc", "worst-probe"});
  r.numbers("probes_hz", models::evaluation_probe_hz(), 1, 16, {0.0, env.fs / 4.0, true, true});
  r.number("rail_penalty", design.training.rail_penalty, {0.0, kMaxRailPenalty, false, false});
  r.number("dc_penalty", design.training.dc_penalty, {0.0, kMaxRailPenalty, false, false});
  r.integer("seed", 1, 0, kMaxSeed);
  // Tuning on a device (panelbass design nn --tune-on): the server's own virtual transducer when it runs one,
  // or a preset; "none": the plant model alone. Training on from a stored controller (--start-from).
  std::vector<std::string> devices = models::plant_preset_names();
  if (env.plant) devices.insert(devices.begin(), "server");
  devices.insert(devices.begin(), "none");
  const std::string tune_on = r.choice("tune_on", "none", devices);
  const long long playbacks = r.integer("tune_playbacks", design.device_playbacks, 1, kMaxPlaybacks);
  require_stored_model(r, "start_from", false, {"neural_feedback"}, env);
  const json* start_from = r.member("start_from");
  if (tune_on == "none" && playbacks != 1) {
    refuse(r.path_of("tune_playbacks"), "plays each drive into the device of tune_on, and tune_on is \"none\"");
  }
  if (tune_on != "none" && (desired != "plant-fundamental" || weighting == "level")) {
    refuse(r.path_of("tune_on"), "tuning on the device asks only each sine step's harmonics of it: it needs desired "
                                 "\"plant-fundamental\" and no level weighting");
  }
  if (start_from != nullptr && !start_from->is_null() && restarts != 1) {
    refuse(r.path_of("start_from"), "training on from a controller is one training, and restarts is " +
                                        std::to_string(restarts));
  }
  return r.finish();
}

json design_nn_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const std::string plant_id = params.at("plant_model").get<std::string>();
  const std::string ff_id = params.at("feedforward_model").get<std::string>();
  progress.at(0.0, "reading " + plant_id + " and " + ff_id);
  const models::LoopPlant plant = models::loop_plant_from_json(stored_model_file(env, plant_id));
  const models::LqFeedforward ff = models::lq_feedforward_from_json(stored_model_file(env, ff_id));
  const LqBandPass band = lq_band_pass(ff);
  const double lo = band.low_hz, hi = band.high_hz;
  const int band_order = band.order;
  const std::vector<dsp::Biquad>& band_pass = band.filter;

  models::FeedbackDesignOptions options;
  options.structure.hidden = hidden_widths(params.at("hidden"));
  options.structure.nu = params.at("nu").get<int>();
  options.structure.nv = params.at("nv").get<int>();
  options.structure.ny = params.at("ny").get<int>();
  options.samples = params.at("samples").get<Eigen::Index>();
  options.sine_share = params.at("sine_share").get<double>();
  options.sine_peak = params.at("sine_peak").get<double>();
  options.program_share = params.at("program_share").get<double>();
  options.desired = models::desired_response_from_name(params.at("desired").get<std::string>());
  const std::string weighting = params.at("weighting").get<std::string>();
  options.level_weighting = weighting == "level";
  options.distortion_weighting = weighting == "distortion";
  options.restarts = params.at("restarts").get<int>();
  options.keep = models::restart_choice_from_name(params.at("keep").get<std::string>());
  options.probe_hz = params.at("probes_hz").get<std::vector<double>>();
  options.seed = params.at("seed").get<std::uint64_t>();
  options.training.max_iterations = params.at("max_iterations").get<int>();
  options.training.rail_penalty = params.at("rail_penalty").get<double>();
  options.training.dc_penalty = params.at("dc_penalty").get<double>();
  options.device_playbacks = params.at("tune_playbacks").get<int>();
  // the device tuned on (the server's own virtual transducer or a preset), and the controller trained on from
  const std::string tune_on = params.at("tune_on").get<std::string>();
  std::optional<models::PlantConfig> device;
  if (tune_on != "none") device = tune_on == "server" ? *env.plant : models::plant_preset(tune_on);
  const json start_param = params.value("start_from", json(nullptr));
  std::optional<models::NeuralFeedback> start;
  if (start_param.is_string()) {
    start = models::neural_feedback_from_json(stored_model_file(env, start_param.get<std::string>()));
    options.structure = start->structure;
  }
  const int total = std::max(1, options.training.max_iterations);
  const int restarts = options.restarts;
  progress.span(0.05, 0.9);
  progress.at(0.0, "training records");
  // Restart r's iterations fill [r/K, (r+1)/K] of the training's span.
  options.training.progress = [&](const models::FeedbackTrainingRecord& rec) {
    const std::string restart =
        restarts > 1 ? "restart " + std::to_string(rec.restart + 1) + "/" + std::to_string(restarts) + ", " : "";
    progress.at((rec.restart + static_cast<double>(rec.iteration) / total) / restarts,
                restart + "closed-loop iteration " + std::to_string(rec.iteration));
  };
  models::FeedbackDesign d = models::design_feedback(plant, ff, band_pass, options, device ? &*device : nullptr,
                                                     start ? &*start : nullptr);

  json training = json::array();
  std::vector<HistoryPoint> history;
  for (const auto& rec : d.training.history) {
    training.push_back({{"iteration", rec.iteration}, {"jc_est_pct", models::number_or_null(rec.jc_est_pct)},
                        {"jc_val_pct", models::number_or_null(rec.jc_val_pct)}, {"rail_fraction", rec.rail_fraction}});
    history.push_back({rec.iteration, rec.jc_est_pct, rec.jc_val_pct});
  }
  json restart_jc_val = json::array();
  for (const double jc : d.restart_jc_val_pct) restart_jc_val.push_back(models::number_or_null(jc));
  json restart_probes = json::array();
  for (const std::vector<double>& changes : d.restart_probe_change_db) {
    restart_probes.push_back(json::array());
    for (const double db : changes) restart_probes.back().push_back(models::number_or_null(db));
  }
  const json design = models::feedback_design_options_json(options);
  d.controller.meta = {{"plant", plant_id},
                       {"feedforward", ff_id},
                       {"bandpass", models::number_text(lo, 4) + "," + models::number_text(hi, 4)},
                       {"order", band_order},
                       {"tuned_on", device ? json(device->name) : json(nullptr)},
                       {"start_from", start_param},
                       {"restart", d.chosen_restart},
                       {"restart_jc_val_pct", restart_jc_val},
                       {"restart_probe_change_db", restart_probes},
                       {"training", training}};
  d.controller.meta.update(design);
  progress.span(0.9, 1.0);
  progress.at(0.0, "storing the controller");
  const std::string name = "nn " + hidden_text(options.structure.hidden) + " on " + plant_id + " (" + control.job_id() + ")";
  const std::string model_id = store_model(env, models::neural_feedback_to_json(d.controller), name, control);

  // Early stopping keeps the parameters of the best validation J_c; its record gives J_c on the estimation
  // data and the rail fraction there.
  const double jc_val_after = models::best_validation_jc_pct(d.training);
  const models::FeedbackTrainingRecord& first = d.training.history.front();
  const models::FeedbackTrainingRecord* kept = models::best_validation_record(d.training);
  const models::FeedbackTrainingRecord& best = kept ? *kept : first;
  json summary = {{"figure", "J_c [2C]: loop output (plant model) against the desired linear response"},
                  {"plant_model", plant_id},
                  {"feedforward_model", ff_id},
                  {"parameters", d.controller.net.parameter_count()},
                  {"iterations", d.training.iterations},
                  {"jc_val_before_pct", models::number_or_null(first.jc_val_pct)},
                  {"jc_val_after_pct", models::number_or_null(jc_val_after)},
                  {"rail_fraction", best.rail_fraction},
                  {"chosen_restart", d.chosen_restart},
                  {"restart_jc_val_pct", restart_jc_val},
                  {"restart_probe_change_db", restart_probes},
                  {"bandpass", {lo, hi}},
                  {"bandpass_order", band_order}};
  summary.update(design);
  progress.at(1.0, "done");
  return {{"model_id", model_id},
          {"j_est_pct", models::number_or_null(best.jc_est_pct)},
          {"j_val_pct", models::number_or_null(jc_val_after)},
          {"summary", summary},
          {"plots", {{"history", history_plot(history)}}}};
}

}  // namespace

JobKind design_nn_job() { return {"design-nn", design_nn_params, design_nn_work, "neural_feedback"}; }

}  // namespace panelbass::api

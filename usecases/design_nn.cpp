#include "usecases/design_nn.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dsp/sample_rate.h"
#include "models/control/loop_plant.h"
#include "models/control/lq_feedforward.h"
#include "models/control/model_probes.h"
#include "models/io/json_fields.h"
#include "models/io/number_text.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

using models::number_or_null;
using models::number_text;
using nlohmann::json;

// The most hidden layers, and nodes in one.
constexpr std::size_t kMaxHiddenLayers = 4;
constexpr int kMaxHiddenWidth = 256;
// The most samples of a training record.
constexpr long long kMaxTrainingSamples = 10'000'000;
// The most training iterations.
constexpr int kMaxTrainingIterations = 10'000;

// Refuses an integer outside [lo, hi], in the words the API's params reader uses for its ranges.
void integer_in(const std::string& field, long long v, long long lo, long long hi) {
  if (v < lo || v > hi) {
    throw RequestError(field, "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                                  std::to_string(v));
  }
}

// Refuses a number outside [lo, hi] ((lo, hi] with lo_open), in the same words.
void number_in(const std::string& field, double v, double lo, double hi, bool lo_open = false) {
  const bool above = lo_open ? v > lo : v >= lo;
  if (!(std::isfinite(v) && above && v <= hi)) {
    throw RequestError(field, "must be a number in " + std::string(lo_open ? "(" : "[") + number_text(lo) + ", " +
                                  number_text(hi) + "], got " + number_text(v));
  }
}

// The file object `file` read by `read`, a refusal naming `field` when it is not of the kind expected.
template <typename Read>
auto read_model(const json& file, const std::string& field, Read&& read) -> decltype(read(file)) {
  try {
    return read(file);
  } catch (const std::exception& e) {
    throw RequestError(field, e.what());
  }
}

json history_json(const std::vector<models::FeedbackTrainingRecord>& history) {
  json h = json::array();
  for (const models::FeedbackTrainingRecord& r : history) {
    h.push_back({{"iteration", r.iteration},
                 {"jc_est_pct", number_or_null(r.jc_est_pct)},
                 {"jc_val_pct", number_or_null(r.jc_val_pct)},
                 {"rail_fraction", r.rail_fraction}});
  }
  return h;
}

}  // namespace

void check(const DesignNnRequest& q) {
  const models::FeedbackDesignOptions& d = q.design;
  integer_in("samples", d.samples, 1000, kMaxTrainingSamples);
  integer_in("max_iterations", d.training.max_iterations, 0, kMaxTrainingIterations);
  if (d.structure.hidden.empty() || d.structure.hidden.size() > kMaxHiddenLayers) {
    throw RequestError("hidden", "must be 1 to " + std::to_string(kMaxHiddenLayers) + " layers, got " +
                                     std::to_string(d.structure.hidden.size()));
  }
  for (const int width : d.structure.hidden) integer_in("hidden", width, 1, kMaxHiddenWidth);
  integer_in("nu", d.structure.nu, 0, kMaxControllerLag);
  integer_in("nv", d.structure.nv, 0, kMaxControllerLag);
  integer_in("ny", d.structure.ny, 0, kMaxControllerLag);
  number_in("sine_share", d.sine_share, 0.0, 1.0);
  number_in("sine_peak", d.sine_peak, 0.0, 1.0, true);
  if (!(std::isfinite(d.sine_low_hz) && d.sine_low_hz > 0.0 && std::isfinite(d.sine_high_hz) && d.sine_high_hz > d.sine_low_hz)) {
    throw RequestError("sine_band", "must be 0 < LO < HI, got " + number_text(d.sine_low_hz) + ", " + number_text(d.sine_high_hz));
  }
  number_in("program_share", d.program_share, 0.0, 1.0);
  if (d.level_weighting && d.distortion_weighting) {
    throw RequestError("weighting", "the level and the distortion weighting exclude each other");
  }
  integer_in("restarts", d.restarts, 1, kMaxFeedbackRestarts);
  for (const double f : d.probe_hz) {
    if (!(std::isfinite(f) && f > 0.0)) throw RequestError("probes_hz", "must be > 0 Hz, got " + number_text(f));
  }
  number_in("rail_penalty", d.training.rail_penalty, 0.0, kMaxFeedbackPenalty);
  number_in("dc_penalty", d.training.dc_penalty, 0.0, kMaxFeedbackPenalty);
  integer_in("tune_playbacks", d.device_playbacks, 1, kMaxDevicePlaybacks);
  if (!q.tune_on && d.device_playbacks != 1) {
    throw RequestError("tune_playbacks", "plays each drive into the device of tune_on, and tune_on is \"none\"");
  }
  if (q.tune_on && (d.desired != models::DesiredResponse::plant_fundamental || d.level_weighting)) {
    throw RequestError("tune_on", "tuning on the device asks only each sine step's harmonics of it: it needs desired "
                                  "\"plant-fundamental\" and no level weighting");
  }
  if (!q.start_from.empty() && d.restarts != 1) {
    throw RequestError("start_from", "training on from a controller is one training, and restarts is " +
                                         std::to_string(d.restarts));
  }
}

json to_json(const DesignNnRequest& q) {
  json fields = models::feedback_design_options_json(q.design);
  for (const char* named_otherwise : {"level_weighting", "distortion_weighting", "device_playbacks", "probe_hz"}) {
    fields.erase(named_otherwise);
  }
  fields.update({{"plant_model", q.plant_name},
                 {"feedforward_model", q.feedforward_name},
                 {"band_pass", q.band_pass ? to_json(*q.band_pass) : json(nullptr)},
                 {"weighting", q.design.level_weighting ? "level" : q.design.distortion_weighting ? "distortion" : "none"},
                 {"probes_hz", q.design.probe_hz.empty() ? models::evaluation_probe_hz() : q.design.probe_hz},
                 {"tune_on", q.tune_on ? json(q.tune_on->name) : json("none")},
                 {"tune_playbacks", q.design.device_playbacks},
                 {"start_from", q.start_from.empty() ? json(nullptr) : json(q.start_from)}});
  return fields;
}

DesignNnReport design_nn(const DesignNnRequest& q, Progress& progress) {
  check(q);
  progress.report(0.0, "reading " + q.plant_name + " and " + q.feedforward_name);
  const models::LoopPlant plant = read_model(q.plant_model, "plant_model", [](const json& f) {
    const std::string kind = f.is_object() ? f.value("kind", "") : "";
    if (kind != "narx" && kind != "ss") {
      throw std::invalid_argument("expected a NARX or state-space (ss) model, got " + (kind.empty() ? "no kind" : kind));
    }
    return models::loop_plant_from_json(f);
  });
  const models::LqFeedforward ff =
      read_model(q.feedforward_model, "feedforward_model", [](const json& f) { return models::lq_feedforward_from_json(f); });
  const BandPass band = q.band_pass ? *q.band_pass : band_pass_of(ff);
  const std::vector<dsp::Biquad> sections = band.sections("band_pass", ff.fs);
  models::FeedbackDesignOptions options = q.design;
  std::optional<models::NeuralFeedback> start;
  if (!q.start_from.empty()) {
    start = read_model(q.start_from_model, "start_from", [](const json& f) { return models::neural_feedback_from_json(f); });
    if (!dsp::same_rate(start->fs, ff.fs)) throw RequestError("start_from", "designed at another rate than the feedforward's");
    options.structure = start->structure;  // the meta says what the controller is
  }
  const int total = std::max(1, options.training.max_iterations);
  const int restarts = options.restarts;
  ProgressSpan training(progress, 0.05, 0.95);
  training.report(0.0, "training records");
  // Restart r's iterations fill [r/K, (r+1)/K] of the training's span.
  options.training.progress = [&](const models::FeedbackTrainingRecord& rec) {
    const std::string restart =
        restarts > 1 ? "restart " + std::to_string(rec.restart + 1) + "/" + std::to_string(restarts) + ", " : "";
    training.report((rec.restart + static_cast<double>(rec.iteration) / total) / restarts,
                    restart + "closed-loop iteration " + std::to_string(rec.iteration));
  };
  models::FeedbackDesign d = models::design_feedback(plant, ff, sections, options, q.tune_on ? &*q.tune_on : nullptr,
                                                     start ? &*start : nullptr);
  options.training.progress = nullptr;

  json restart_jc_val = json::array();
  for (const double jc : d.restart_jc_val_pct) restart_jc_val.push_back(number_or_null(jc));
  json restart_probes = json::array();
  for (const std::vector<double>& changes : d.restart_probe_change_db) {
    restart_probes.push_back(json::array());
    for (const double db : changes) restart_probes.back().push_back(number_or_null(db));
  }
  DesignNnReport report;
  report.history = history_json(d.training.history);
  const json design = models::feedback_design_options_json(options);
  d.controller.meta = {{"plant", q.plant_name},
                       {"plant_kind", plant.kind()},
                       {"feedforward", q.feedforward_name},
                       {"bandpass", number_text(band.low_hz, 4) + "," + number_text(band.high_hz, 4)},
                       {"order", band.order},
                       {"tuned_on", q.tune_on ? json(q.tune_on->name) : json(nullptr)},
                       {"start_from", q.start_from.empty() ? json(nullptr) : json(q.start_from)},
                       {"restart", d.chosen_restart},
                       {"restart_jc_val_pct", restart_jc_val},
                       {"restart_probe_change_db", restart_probes},
                       {"training", report.history}};
  d.controller.meta.update(design);
  // Early stopping keeps the parameters of the best validation J_c; its record gives J_c on the estimation data and
  // the rail fraction there.
  const models::FeedbackTrainingRecord& first = d.training.history.front();
  const models::FeedbackTrainingRecord* kept = models::best_validation_record(d.training);
  const models::FeedbackTrainingRecord& best = kept ? *kept : first;
  report.jc_est_pct = best.jc_est_pct;
  report.summary = {{"figure", "J_c [2C]: loop output (plant model) against the desired linear response"},
                    {"plant_model", q.plant_name},
                    {"feedforward_model", q.feedforward_name},
                    {"parameters", d.controller.net.parameter_count()},
                    {"iterations", d.training.iterations},
                    {"jc_val_before_pct", number_or_null(first.jc_val_pct)},
                    {"jc_val_after_pct", number_or_null(models::best_validation_jc_pct(d.training))},
                    {"rail_fraction", best.rail_fraction},
                    {"chosen_restart", d.chosen_restart},
                    {"restart_jc_val_pct", restart_jc_val},
                    {"restart_probe_change_db", restart_probes},
                    {"bandpass", {band.low_hz, band.high_hz}},
                    {"bandpass_order", band.order}};
  report.summary.update(design);
  report.controller = std::move(d.controller);
  report.training = std::move(d.training);
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases

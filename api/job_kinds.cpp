#include "api/job_kinds.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "api/job_params.h"
#include "api/job_plots.h"
#include "api/model_validation.h"
#include "dsp/butterworth.h"
#include "dsp/excitation.h"
#include "engine/chain_evaluation.h"
#include "engine/chain_file.h"
#include "engine/distortion_attribution.h"
#include "engine/evaluation_json.h"
#include "models/linear/data_survey.h"
#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/diagnosis_baselines.h"
#include "models/analysis/distortion_comparison.h"
#include "models/narx/friction_seed.h"
#include "models/control/feedback_design.h"
#include "models/linear/linear_identification.h"
#include "models/linear/linear_model.h"
#include "models/control/lq_feedforward.h"
#include "models/control/lq_weight_search.h"
#include "models/analysis/model_analysis.h"
#include "models/kinds/model_file.h"
#include "models/narx/narx_model.h"
#include "models/narx/narx_training.h"
#include "models/control/neural_feedback.h"
#include "models/validation/performance.h"
#include "models/plant/plant_presets.h"
#include "models/preprocess/scaling.h"
#include "models/linear/state_space.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Measured outputs that set a simulation's state before J is computed (the CLI's --init default).
constexpr Eigen::Index kInit = 50;
// Share of a job's progress given to an excitation of its own.
constexpr double kExcitationShare = 0.1;
// The LQ weight on the model output (the CLI's --R0 default; the API exposes R only).
constexpr double kLqR0 = 20.0;
// Uniform-noise samples behind the LQ design's max_input_noise figure.
constexpr Eigen::Index kLqNoiseSamples = 20000;
// Stepped-sine fundamentals (Hz) of the harmonics plot, and its samples per step.
const std::vector<double> kHarmonicFrequencies{50.0, 100.0, 200.0, 400.0};
constexpr std::size_t kHarmonicSettle = 300, kHarmonicMeasure = 1500;

// ----- progress -----------------------------------------------------------------------------------

// Progress of one job: a stage's own fraction is mapped onto its span [lo, hi] of the job, and the
// reported fraction never goes back. JobCancelled thrown by the control unwinds whatever called us.
class Progress {
 public:
  explicit Progress(JobControl& control) : control_(control) {}
  // The next stage covers [lo, hi] of the job.
  void span(double lo, double hi) {
    lo_ = lo;
    hi_ = hi;
  }
  // Reports `fraction` of the current stage.
  void at(double fraction, const std::string& message) {
    const double f = lo_ + (hi_ - lo_) * std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
    last_ = std::max(last_, f);
    control_.progress(last_, message);
  }

 private:
  JobControl& control_;
  double lo_ = 0.0, hi_ = 1.0, last_ = 0.0;
};

// ----- helpers -------------------------------------------------------------------------------------

std::string number_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g", v);
  return text;
}

json roots_json(const Eigen::VectorXcd& roots) {
  json out = json::array();
  for (Eigen::Index k = 0; k < roots.size(); ++k) out.push_back({roots[k].real(), roots[k].imag()});
  return out;
}

json row_json(const Eigen::RowVectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

std::vector<int> ints_of(const json& list) {
  std::vector<int> out;
  for (const json& v : list) out.push_back(v.get<int>());
  return out;
}

std::string hidden_text(const std::vector<int>& hidden) {
  std::string text = "[";
  for (std::size_t k = 0; k < hidden.size(); ++k) text += (k ? "," : "") + std::to_string(hidden[k]);
  return text + "]";
}

double rms(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::Index n = a.size() + b.size();
  return n > 0 ? std::sqrt((a.squaredNorm() + b.squaredNorm()) / static_cast<double>(n)) : 0.0;
}

double peak(const Eigen::VectorXd& x) { return x.size() ? x.cwiseAbs().maxCoeff() : 0.0; }

// The stored model file `id` (checked when the params were; gone since → the job fails).
json stored_model_file(const JobEnvironment& env, const std::string& id) {
  if (env.store == nullptr) throw std::runtime_error("no model store");
  std::optional<json> model = env.store->model(id);
  if (!model) throw std::runtime_error("model " + id + " is no longer stored");
  return *model;
}

// Validates `model` and stores it with the job as its source; returns its id.
std::string store_model(const JobEnvironment& env, const json& model, const std::string& name, const JobControl& control) {
  if (env.store == nullptr) throw std::runtime_error("no model store to keep the model in");
  const ValidatedModel valid = validate_model(model);
  return env.store->put(model, valid.kind, valid.fs, name, control.job_id()).id;
}

// ----- excitation ----------------------------------------------------------------------------------

// The drive of `samples`: uniform white noise in [−amplitude, amplitude] or a random-phase multisine
// over the whole band with that peak; clamped to [−1, 1] (the safety rule).
Eigen::VectorXd excitation_signal(const std::string& signal, Eigen::Index samples, double amplitude, std::uint64_t seed,
                                  double fs) {
  Eigen::VectorXd drive;
  if (signal == "multisine") {
    dsp::MultisineSpec spec;
    spec.period = static_cast<std::size_t>(std::min<Eigen::Index>(4096, samples));
    spec.periods = static_cast<std::size_t>((samples + spec.period - 1) / spec.period);
    spec.fs = fs;
    spec.f_min = 0.0;
    spec.f_max = fs / 2.0;
    spec.amplitude = amplitude;
    spec.seed = seed;
    drive = dsp::multisine(spec).signal.head(samples);
  } else {
    drive = dsp::uniform_noise(static_cast<std::size_t>(samples), amplitude, seed);
  }
  if (!drive.allFinite()) throw std::runtime_error("the excitation has a non-finite sample");
  return drive.cwiseMax(-1.0).cwiseMin(1.0);
}

// Plays `drive` through the backend; the response must be as long and finite.
Eigen::VectorXd play(const JobEnvironment& env, const Eigen::VectorXd& drive) {
  if (!env.excite) throw std::runtime_error("no backend to excite");
  Eigen::VectorXd response = env.excite(drive);
  if (response.size() != drive.size()) {
    throw std::runtime_error("the backend recorded " + std::to_string(response.size()) + " samples for a drive of " +
                             std::to_string(drive.size()));
  }
  if (!response.allFinite()) throw std::runtime_error("the backend recorded a non-finite response");
  return response;
}

// The band-pass an LQ controller was designed behind (its meta, as `design lq` writes it), else 20–1200 Hz
// of order 2 (the low-pass corner kept below Nyquist).
std::vector<dsp::Biquad> band_pass_of(const models::LqFeedforward& ff, double& lo, double& hi, int& order) {
  lo = 20.0;
  hi = std::min(1200.0, 0.45 * ff.fs);
  order = 2;
  const json& meta = ff.meta;
  if (meta.is_object() && meta.contains("bandpass") && meta["bandpass"].is_array() && meta["bandpass"].size() == 2 &&
      meta["bandpass"][0].is_number() && meta["bandpass"][1].is_number()) {
    const double l = meta["bandpass"][0].get<double>(), h = meta["bandpass"][1].get<double>();
    if (l >= 0.0 && h > l && h < ff.fs / 2.0) {
      lo = l;
      hi = h;
    }
  }
  if (meta.is_object() && meta.contains("bandpass_order") && meta["bandpass_order"].is_number_integer()) {
    const int o = meta["bandpass_order"].get<int>();
    if (o >= 1 && o <= 16) order = o;
  }
  return dsp::butterworth_band(order, lo, hi, ff.fs);
}

// Runs the excitation of filled-in excite params: estimation part (seed), then validation part (seed + 1).
ExcitationRecord run_excitation(const json& excite, const JobEnvironment& env, Progress& progress) {
  const std::string signal = excite.at("signal").get<std::string>();
  const Eigen::Index samples = excite.at("samples").get<Eigen::Index>();
  const Eigen::Index validation = excite.at("validation_samples").get<Eigen::Index>();
  const double amplitude = excite.at("amplitude").get<double>();
  const std::uint64_t seed = excite.at("seed").get<std::uint64_t>();
  const double total = static_cast<double>(samples + validation);
  ExcitationRecord record;
  progress.at(0.0, "excitation: " + std::to_string(samples) + " samples of " + signal);
  if (signal == "control") {
    const models::LqFeedforward ff =
        models::lq_feedforward_from_json(stored_model_file(env, excite.at("feedforward_model").get<std::string>()));
    double lo = 0.0, hi = 0.0;
    int order = 0;
    const std::vector<dsp::Biquad> band_pass = band_pass_of(ff, lo, hi, order);
    models::FeedbackDesignOptions design;
    design.sine_peak = excite.at("sine_peak").get<double>();
    design.program_share = excite.at("program_share").get<double>();
    // One part: the chain's drive for the design's program, played, and its steps' harmonic weights.
    const auto control_part = [&](Eigen::Index n, std::uint64_t part_seed, Eigen::VectorXd& u, Eigen::VectorXd& y,
                                  Eigen::VectorXd& w) {
      design.samples = n;
      const models::ControlRecord part = models::control_record(ff, band_pass, design, part_seed);
      if (!part.u.allFinite()) throw std::runtime_error("the control excitation has a non-finite sample");
      u = part.u.cwiseMax(-1.0).cwiseMin(1.0);
      y = play(env, u);
      w = models::harmonic_weights(part, y, env.fs);
    };
    control_part(samples, seed, record.u_est, record.y_est, record.w_est);
    if (validation > 0) {
      progress.at(samples / total, "excitation: " + std::to_string(validation) + " validation samples");
      control_part(validation, seed + 1, record.u_val, record.y_val, record.w_val);
    }
    progress.at(1.0, "excitation recorded");
    return record;
  }
  record.u_est = excitation_signal(signal, samples, amplitude, seed, env.fs);
  record.y_est = play(env, record.u_est);
  if (validation > 0) {
    progress.at(samples / total, "excitation: " + std::to_string(validation) + " validation samples");
    record.u_val = excitation_signal(signal, validation, amplitude, seed + 1, env.fs);
    record.y_val = play(env, record.u_val);
  }
  progress.at(1.0, "excitation recorded");
  return record;
}

// The data of an identify/analyze/diagnose job and where it came from ("job j3" or "excitation of j5").
struct SourcedRecord {
  ExcitationRecord record;
  std::string source;
};

SourcedRecord acquire_record(const json& params, const JobEnvironment& env, Progress& progress, const JobControl& control) {
  progress.span(0.0, kExcitationShare);
  if (params.contains("record") && params.at("record").is_string()) {
    const std::string id = params.at("record").get<std::string>();
    const std::optional<json> result = env.job_result ? env.job_result(id) : std::nullopt;
    if (!result) throw std::runtime_error("params.record: job " + id + " is no longer available");
    progress.at(1.0, "record of " + id);
    return {excitation_record_from_result(*result, env.fs, "params.record: job " + id), "job " + id};
  }
  return {run_excitation(params.at("excite"), env, progress), "excitation of " + control.job_id()};
}

// The part of a record a model is judged on: validation when there is one, else estimation.
struct Judged {
  const Eigen::VectorXd& u;
  const Eigen::VectorXd& y;
  bool validation;
};

Judged judged_part(const ExcitationRecord& r) {
  if (r.u_val.size() > 0) return {r.u_val, r.y_val, true};
  return {r.u_est, r.y_est, false};
}

// [2A] simulation J of `model` with the first min(kInit, N/10) measured outputs setting its state.
double simulation_j(const models::AnyModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y) {
  if (u.size() == 0) return kNaN;
  const Eigen::Index init = std::min<Eigen::Index>(kInit, u.size() / 10);
  return models::j_percent(model.simulate(u, y, init), y, init);
}

// "fit" and "spectrum" of `model` on the judged part of `r`.
json model_plots(const models::AnyModel& model, const ExcitationRecord& r, double fs) {
  const Judged part = judged_part(r);
  const Eigen::Index init = std::min<Eigen::Index>(kInit, part.u.size() / 10);
  const Eigen::VectorXd y_sim = model.simulate(part.u, part.y, init);
  const Eigen::Index n = part.u.size() - init;
  return {{"fit", fit_plot(part.y.tail(n), y_sim.tail(n), fs, init)},
          {"spectrum", spectrum_plot(part.u, part.y, model.simulate(part.u), fs)}};
}

// The plant's and the model's H2/H3 by stepped sine at the record's drive level, when the plant is known
// and runs at the model's rate; null otherwise.
json harmonics_if_known(const JobEnvironment& env, const models::AnyModel& model, const ExcitationRecord& r,
                        Progress& progress) {
  if (!env.plant || std::abs(env.plant->fs - model.fs()) > 1e-9 * model.fs()) return nullptr;
  progress.at(0.0, "harmonic distortion of plant and model");
  models::DistortionSpec spec;
  spec.frequencies = kHarmonicFrequencies;
  spec.amplitudes = {std::clamp(peak(r.u_est), 1e-3, 1.0)};
  spec.settle = kHarmonicSettle;
  spec.measure = kHarmonicMeasure;
  spec.max_order = 3;
  return harmonics_plot(models::compare_distortion(*env.plant, model, spec));
}

// ----- the kinds ------------------------------------------------------------------------------------

json excite_work(const json& params, const JobEnvironment& env, JobControl& control) {
  Progress progress(control);
  progress.span(0.0, 0.95);
  const ExcitationRecord r = run_excitation(params, env, progress);
  const Eigen::Index n = std::min<Eigen::Index>(2000, r.u_est.size());
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(n, 0.0, static_cast<double>(n - 1)) / env.fs;
  json result = {{"fs", env.fs},
                 {"signal", params.at("signal")},
                 {"amplitude", params.at("amplitude")},
                 {"seed", params.at("seed")},
                 {"samples", r.u_est.size()},
                 {"validation_samples", r.u_val.size()},
                 {"rms_drive", rms(r.u_est, r.u_val)},
                 {"rms_response", rms(r.y_est, r.y_val)},
                 {"plots",
                  {{"fit", {{"t", column(t)}, {"drive", column(r.u_est.head(n))}, {"measured", column(r.y_est.head(n))}}}}},
                 {"record", excitation_record_to_json(r)}};
  progress.span(0.0, 1.0);
  progress.at(1.0, "done");
  return result;
}

json identify_linear_work(const json& params, const JobEnvironment& env, JobControl& control) {
  Progress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  const ExcitationRecord& r = data.record;

  models::LinearIdentificationSpec spec;
  spec.method = models::parse_linear_method(params.at("method").get<std::string>());
  spec.order = params.at("order").get<int>();
  spec.delay = params.at("delay").get<int>();
  const bool scanning = params.at("scan").is_array();
  if (scanning) {
    spec.scan_from = params.at("scan")[0].get<int>();
    spec.scan_to = params.at("scan")[1].get<int>();
  }
  spec.init = kInit;
  spec.fs = env.fs;
  spec.oe.max_iterations = params.at("max_iterations").get<int>();

  // J per output-error iteration of the final fit: the OE loss (mean squared simulation error, scaled
  // units) over the mean square of the scaled output, the [2A] ratio from rest.
  const models::Scaling scaling = models::scaling_from_data(r.u_est, r.y_est);
  const double output_power = scaling.scale_y(r.y_est).squaredNorm() / static_cast<double>(r.y_est.size());
  const int fits = scanning ? spec.scan_to - spec.scan_from + 2 : 1;
  double base = 0.0;
  std::vector<HistoryPoint> history;
  const std::string method = params.at("method").get<std::string>();
  progress.span(kExcitationShare, 0.9);
  spec.progress = [&](const std::string& stage, double f) {
    if (f == 0.0 || stage == "scan") history.clear();  // a fit starts; the last one's iterations are kept
    base = stage == "scan" ? f * (fits - 1) / fits : stage == "fit" ? static_cast<double>(fits - 1) / fits : 0.0;
    progress.at(base, method + ": " + stage);
  };
  spec.oe.progress = [&](int iteration, double loss) {
    history.push_back({iteration, output_power > 0.0 ? 100.0 * loss / output_power : kNaN, kNaN});
    progress.at(base + static_cast<double>(iteration) / spec.oe.max_iterations / fits,
                method + " iteration " + std::to_string(iteration));
  };
  models::LinearIdentification id = models::identify_linear(r.u_est, r.y_est, r.u_val, r.y_val, spec);

  progress.span(0.9, 1.0);
  progress.at(0.0, "storing the model");
  id.model.meta = {{"data", data.source + " (estimation)"},
                   {"val", r.u_val.size() ? json(data.source + " (validation)") : json("")},
                   {"na", id.model.tf.na()},
                   {"nb", id.model.tf.nb()},
                   {"nk", id.model.tf.nk},
                   {"J_est_pct", id.j_est_pct},
                   {"J_val_pct", finite_or_null(id.j_val_pct)}};
  const int order = id.model.tf.na() > 0 ? id.model.tf.na() : id.model.tf.nb();
  const std::string model_id = store_model(env, models::linear_model_to_json(id.model),
                                           method + " order " + std::to_string(order) + " (" + control.job_id() + ")", control);

  const std::string history_source = history.empty() ? "the final model" : "output-error iterations of the final fit (from rest)";
  if (history.empty()) history.push_back({0, id.j_est_pct, id.j_val_pct});
  json summary = {{"method", method},
                  {"order", order},
                  {"na", id.model.tf.na()},
                  {"nb", id.model.tf.nb()},
                  {"delay", id.model.tf.nk},
                  {"J_pred_est_pct", id.j_pred_est_pct},
                  {"poles", roots_json(id.model.tf.poles())},
                  {"zeros", roots_json(id.model.tf.zeros())},
                  {"survey", models::data_survey_to_json(id.survey)},
                  {"data", data.source},
                  {"history_source", history_source}};
  if (!id.scan.empty()) {
    json scan = json::array();
    for (const auto& e : id.scan) scan.push_back({{"order", e.order}, {"J_est_pct", e.j_est_pct}, {"J_val_pct", e.j_val_pct}});
    summary["scan"] = scan;
    summary["order_rule"] = id.order_rule;
    summary["scan_skipped"] = id.scan_skipped;
  }
  const models::AnyModel any{id.model};
  json plots = model_plots(any, r, env.fs);
  plots["history"] = history_plot(history);
  progress.at(1.0, "done");
  return {{"model_id", model_id},
          {"j_est_pct", id.j_est_pct},
          {"j_val_pct", finite_or_null(id.j_val_pct)},
          {"summary", summary},
          {"plots", plots}};
}

json identify_narx_work(const json& params, const JobEnvironment& env, JobControl& control) {
  Progress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  const ExcitationRecord& r = data.record;

  const models::Scaling scaling = models::scaling_from_data(r.u_est, r.y_est);
  int nk = params.at("nk").get<int>();
  if (nk < 0) nk = models::survey_data(r.u_est, r.y_est).delay;
  const models::NarxStructure structure{params.at("na").get<int>(), params.at("nb").get<int>(), nk,
                                        ints_of(params.at("hidden"))};
  const std::uint64_t seed = params.at("seed").get<std::uint64_t>();
  models::NarxModel model = models::NarxModel::with_structure(structure, scaling, env.fs);
  model.net.initialize(1.0, seed);
  const Eigen::VectorXd us = scaling.scale_u(r.u_est), ys = scaling.scale_y(r.y_est);
  const Eigen::VectorXd uv = r.u_val.size() ? scaling.scale_u(r.u_val) : Eigen::VectorXd(),
                        yv = r.y_val.size() ? scaling.scale_y(r.y_val) : Eigen::VectorXd();
  json friction = nullptr;
  if (const auto gains = params.value("friction_units", std::vector<double>{}); !gains.empty()) {
    friction = models::friction_seed_report(
        models::seed_friction_units(model, us, ys, gains, params.value("friction_lags", 1)));
  }

  models::TrainingOptions options;
  options.modes.clear();
  std::string train;
  for (const json& m : params.at("modes")) {
    options.modes.push_back(models::parse_training_mode(m.get<std::string>()));
    train += (train.empty() ? "" : ",") + m.get<std::string>();
  }
  options.optimizer = models::Optimizer::lm;
  options.max_iterations = params.at("max_iterations").get<int>();
  const bool weighted = params.value("weighted", false);
  if (weighted) {
    if (r.w_est.size() == 0) throw std::invalid_argument("params.weighted: the record has no harmonic weights");
    options.weights = r.w_est;
    options.validation_weights = r.w_val;
  }
  const int total = std::max(1, options.max_iterations * static_cast<int>(options.modes.size()));
  progress.span(kExcitationShare, 0.85);
  options.progress = [&](const models::TrainingRecord& rec) {
    progress.at(static_cast<double>(rec.iteration) / total,
                models::to_string(rec.mode) + " iteration " + std::to_string(rec.iteration));
  };
  models::TrainingResult trained = models::train_narx(model, us, ys, uv, yv, options);

  progress.span(0.85, 1.0);
  progress.at(0.0, "judging the model");
  const models::AnyModel judged{trained.model};
  const double j_est = simulation_j(judged, r.u_est, r.y_est);
  const double j_val = simulation_j(judged, r.u_val, r.y_val);
  json meta_history = json::array();
  std::vector<HistoryPoint> history;
  for (std::size_t k = 0; k < trained.history.size(); ++k) {
    const models::TrainingRecord& rec = trained.history[k];
    meta_history.push_back({{"iter", rec.iteration}, {"mode", models::to_string(rec.mode)},
                            {"J_est_pct", finite_or_null(rec.j_est_pct)}, {"J_val_pct", finite_or_null(rec.j_val_pct)}});
    history.push_back({rec.iteration, rec.j_est_pct, rec.j_val_pct});
  }
  trained.model.meta = {{"data", data.source + " (estimation)"},
                        {"val", r.u_val.size() ? json(data.source + " (validation)") : json("")},
                        {"train", train},
                        {"optimizer", "lm"},
                        {"J_est_pct", j_est},
                        {"J_val_pct", finite_or_null(j_val)},
                        {"seed", seed},
                        {"weighted", weighted},
                        {"history", meta_history}};
  if (!friction.is_null()) trained.model.meta["friction_units"] = friction;
  progress.at(0.2, "storing the model");
  const std::string name = "narx " + std::to_string(structure.na) + "/" + std::to_string(structure.nb) + "/" +
                           std::to_string(structure.nk) + " " + hidden_text(structure.hidden) + " (" + control.job_id() + ")";
  const std::string model_id = store_model(env, models::narx_model_to_json(trained.model), name, control);

  const models::AnyModel any{trained.model};
  json plots = model_plots(any, r, env.fs);
  plots["history"] = history_plot(history);
  progress.span(0.9, 1.0);
  const json harmonics = harmonics_if_known(env, any, r, progress);
  if (!harmonics.is_null()) plots["harmonics"] = harmonics;
  progress.at(1.0, "done");
  json result = {{"model_id", model_id},
                 {"j_est_pct", j_est},
                 {"j_val_pct", finite_or_null(j_val)},
                 {"summary",
                  {{"na", structure.na},
                   {"nb", structure.nb},
                   {"nk", structure.nk},
                   {"hidden", structure.hidden},
                   {"modes", params.at("modes")},
                   {"params", trained.model.net.parameter_count()},
                   {"iterations", trained.iterations},
                   {"seconds", trained.seconds},
                   {"weighted", weighted},
                   {"data", data.source}}},
                 {"plots", plots}};
  if (!friction.is_null()) result["summary"]["friction_units"] = friction;
  return result;
}

// `count` frequencies spaced logarithmically from `lo` to `hi` Hz.
Eigen::VectorXd log_grid(double lo, double hi, Eigen::Index count) {
  return Eigen::VectorXd::LinSpaced(count, std::log(lo), std::log(hi)).array().exp();
}

Eigen::VectorXcd frequency_response(const models::StateSpace& ss, const Eigen::VectorXd& f, double fs) {
  Eigen::VectorXcd h(f.size());
  for (Eigen::Index k = 0; k < f.size(); ++k) h[k] = models::response(ss, f[k], fs);
  return h;
}

json design_lq_work(const json& params, const JobEnvironment& env, JobControl& control) {
  Progress progress(control);
  const std::string plant_id = params.at("plant_model").get<std::string>();
  progress.at(0.0, "reading " + plant_id);
  const models::LinearModel model = models::linear_model_from_json(stored_model_file(env, plant_id));
  const json& band = params.at("band_pass");
  const double lo = band.at("low_hz").get<double>(), hi = band.at("high_hz").get<double>();
  const int band_order = band.at("order").get<int>();
  if (!(hi < model.fs / 2.0)) {
    throw std::invalid_argument("params.band_pass.high_hz: " + number_text(hi) +
                                " Hz is not below the model's Nyquist frequency");
  }
  const std::vector<dsp::Biquad> band_pass = dsp::butterworth_band(band_order, lo, hi, model.fs);

  const std::uint64_t seed = 1;
  models::LqFeedforward ff;
  models::InputLimits limits;
  json search = nullptr;
  if (params.contains("max_input")) {
    const double target = params.at("max_input").get<double>();
    progress.at(0.1, "searching R for a safe program amplitude of " + number_text(target));
    models::LqWeightSearch found = models::design_lq_for_input(model, kLqR0, target, band_pass, kLqNoiseSamples, seed);
    ff = std::move(found.ff);
    limits = found.limits;
    search = models::lq_weight_search_report(found);
  } else {
    progress.at(0.1, "LQ design, R = " + number_text(params.at("r").get<double>()));
    ff = models::design_lq(model, {params.at("r").get<double>(), kLqR0});
    progress.at(0.4, "largest safe program amplitude");
    limits = models::max_input(ff, band_pass, kLqNoiseSamples, seed);
  }
  const double r_weight = ff.weights.R;
  const models::DrivePeak peak = models::drive_peak(ff, band_pass);
  ff.meta = {{"model", plant_id},
             {"model_method", model.method},
             {"order", ff.plant.order()},
             {"weights", {{"R", r_weight}, {"R0", kLqR0}}},
             {"bandpass", {lo, hi}},
             {"bandpass_order", band_order},
             {"max_input", {{"worst", limits.worst}, {"noise", limits.noise}, {"samples", kLqNoiseSamples}, {"seed", seed}}}};
  if (!search.is_null()) ff.meta["R_search"] = search;
  progress.at(0.8, "storing the controller");
  const std::string name = "lq R=" + number_text(r_weight) + " on " + plant_id + " (" + control.job_id() + ")";
  const std::string model_id = store_model(env, models::lq_feedforward_to_json(ff), name, control);

  const Eigen::VectorXd f = log_grid(10.0, 0.49 * ff.fs, 200);
  const Eigen::VectorXcd poles = ff.poles();
  json result = {{"model_id", model_id},
                 {"j_est_pct", nullptr},
                 {"j_val_pct", nullptr},
                 {"summary",
                  {{"plant_model", plant_id},
                   {"order", ff.plant.order()},
                   {"R", r_weight},
                   {"R_search", search},
                   {"R0", kLqR0},
                   {"L", row_json(ff.L)},
                   {"poles", roots_json(poles)},
                   {"zeros", roots_json(ff.zeros())},
                   {"pole_radius", poles.size() ? poles.cwiseAbs().maxCoeff() : 0.0},
                   {"bandpass", {lo, hi}},
                   {"bandpass_order", band_order},
                   {"max_input_worst", limits.worst},
                   {"max_input_noise", limits.noise},
                   {"drive_peak", {{"frequency_hz", peak.frequency_hz}, {"gain_db", peak.gain_db}}},
                   {"unity_gain_hz", models::unity_gain_hz(ff)}}},
                 {"plots",
                  {{"spectrum",
                    {{"f", column(f)},
                     {"plant_db", column(magnitude_db(frequency_response(ff.plant, f, ff.fs)))},
                     {"controlled_db", column(magnitude_db(frequency_response(ff.desired(), f, ff.fs)))},
                     {"controller_db", column(magnitude_db(frequency_response(ff.controller(), f, ff.fs)))}}}}}};
  progress.at(1.0, "done");
  return result;
}

json design_nn_work(const json& params, const JobEnvironment& env, JobControl& control) {
  Progress progress(control);
  const std::string plant_id = params.at("plant_model").get<std::string>();
  const std::string ff_id = params.at("feedforward_model").get<std::string>();
  progress.at(0.0, "reading " + plant_id + " and " + ff_id);
  const models::NarxModel plant = models::narx_model_from_json(stored_model_file(env, plant_id));
  const models::LqFeedforward ff = models::lq_feedforward_from_json(stored_model_file(env, ff_id));
  double lo = 0.0, hi = 0.0;
  int band_order = 2;
  const std::vector<dsp::Biquad> band_pass = band_pass_of(ff, lo, hi, band_order);

  models::FeedbackDesignOptions options;
  options.structure.hidden = ints_of(params.at("hidden"));
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
    training.push_back({{"iteration", rec.iteration}, {"jc_est_pct", finite_or_null(rec.jc_est_pct)},
                        {"jc_val_pct", finite_or_null(rec.jc_val_pct)}, {"rail_fraction", rec.rail_fraction}});
    history.push_back({rec.iteration, rec.jc_est_pct, rec.jc_val_pct});
  }
  json restart_jc_val = json::array();
  for (const double jc : d.restart_jc_val_pct) restart_jc_val.push_back(finite_or_null(jc));
  json restart_probes = json::array();
  for (const std::vector<double>& changes : d.restart_probe_change_db) {
    restart_probes.push_back(json::array());
    for (const double db : changes) restart_probes.back().push_back(finite_or_null(db));
  }
  const json design = models::feedback_design_options_json(options);
  d.controller.meta = {{"plant", plant_id},
                       {"feedforward", ff_id},
                       {"bandpass", number_text(lo) + "," + number_text(hi)},
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
                  {"jc_val_before_pct", finite_or_null(first.jc_val_pct)},
                  {"jc_val_after_pct", finite_or_null(jc_val_after)},
                  {"rail_fraction", best.rail_fraction},
                  {"chosen_restart", d.chosen_restart},
                  {"restart_jc_val_pct", restart_jc_val},
                  {"restart_probe_change_db", restart_probes},
                  {"bandpass", {lo, hi}},
                  {"bandpass_order", band_order}};
  summary.update(design);
  progress.at(1.0, "done");
  return {{"model_id", model_id},
          {"j_est_pct", finite_or_null(best.jc_est_pct)},
          {"j_val_pct", finite_or_null(jc_val_after)},
          {"summary", summary},
          {"plots", {{"history", history_plot(history)}}}};
}

// The plot columns' prefix for evaluation row `row` (plant, band-pass + feedforward, + feedback).
const char* evaluation_row_key(std::size_t row) {
  static const char* const kKeys[] = {"plant", "feedforward", "feedback"};
  return row < 3 ? kKeys[row] : "row";
}

// A chain of stored controllers (the feedforward's band-pass, the LQ feedforward, the neural feedback if any)
// evaluated on a virtual transducer, as panelbass chain + evaluate [--attribute].
json evaluate_work(const json& params, const JobEnvironment& env, JobControl& control) {
  Progress progress(control);
  const std::string ff_id = params.at("feedforward_model").get<std::string>();
  const json fb_param = params.value("feedback_model", json(nullptr));  // absent or null: no feedback stage
  const std::string fb_id = fb_param.is_string() ? fb_param.get<std::string>() : "";
  progress.at(0.0, "reading " + ff_id + (fb_id.empty() ? "" : " and " + fb_id));
  engine::ChainConfig config;
  config.fs = env.fs;
  config.feedforward = engine::SlotConfig{};
  config.feedforward->model = stored_model_file(env, ff_id);
  double lo = 0.0, hi = 0.0;
  int band_order = 2;
  band_pass_of(models::lq_feedforward_from_json(config.feedforward->model), lo, hi, band_order);
  config.band_pass.design = {engine::Hertz{lo}, engine::Hertz{hi}, band_order};
  if (!fb_id.empty()) {
    config.feedback = engine::SlotConfig{};
    config.feedback->model = stored_model_file(env, fb_id);
    config.feedback->source =
        params.at("source").get<std::string>() == "sensor" ? engine::FeedbackSource::sensor : engine::FeedbackSource::model;
  }
  const std::string plant_name = params.at("plant").get<std::string>();
  const models::PlantConfig plant = plant_name == "server" ? *env.plant : models::plant_preset(plant_name);
  engine::EvaluationOptions options;
  options.probe_hz = params.at("probes_hz").get<std::vector<double>>();
  options.probe_peak = params.at("probe_peak").get<double>();
  options.noise_samples = params.at("noise_samples").get<Eigen::Index>();
  options.seed = params.at("seed").get<std::uint64_t>();
  const bool attribute = params.at("attribute").get<bool>();

  progress.at(0.05, "evaluating the chain on " + plant.name);
  const engine::ChainEvaluation e = engine::evaluate_chain(config, plant, options);
  json rows = json::array();
  for (const engine::EvaluationRow& row : e.rows) rows.push_back(engine::evaluation_row_to_json(row));
  // The table at a glance: each row's ripple, J_c and THD per probe.
  json table = json::object();
  json response = {{"f", column(e.rows.front().response_hz)}};
  json thd = {{"f", options.probe_hz}};
  for (std::size_t k = 0; k < e.rows.size(); ++k) {
    const engine::EvaluationRow& row = e.rows[k];
    json row_thd = json::array();
    for (const engine::ProbeResult& p : row.probes) row_thd.push_back(p.thd_pct);
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
    const std::vector<engine::TermDistortion> terms = engine::attribute_distortion(
        config, plant, options, [&](std::size_t done, std::size_t total, const std::string& term) {
          progress.at(static_cast<double>(done) / static_cast<double>(total), "evaluating with only the " + term + " on");
        });
    // Each term's THD per probe behind band-pass + feedforward: what a feedback stage is there to remove.
    json by_term = json::object();
    for (const engine::TermDistortion& t : terms) {
      json term_thd = json::array();
      for (const engine::ProbeResult& p : t.rows.at(1).probes) term_thd.push_back(p.thd_pct);
      by_term[t.term] = term_thd;
    }
    result["summary"]["attribution_thd_pct"] = by_term;
    result["attribution"] = engine::attribution_to_json(terms);
  }
  progress.at(1.0, "done");
  return result;
}

json analyze_work(const json& params, const JobEnvironment& env, JobControl& control) {
  Progress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  const ExcitationRecord& r = data.record;
  const std::string model_id = params.at("model").get<std::string>();
  const json file = stored_model_file(env, model_id);
  const models::AnyModel model = models::model_from_json(file);
  const Judged part = judged_part(r);

  models::AnalysisSpec spec;
  spec.init = std::min<Eigen::Index>(kInit, part.u.size() / 10);
  if (env.plant && std::abs(env.plant->fs - model.fs()) <= 1e-9 * model.fs()) {
    spec.plant = env.plant;
    spec.distortion.frequencies = kHarmonicFrequencies;
    spec.distortion.amplitudes = {std::clamp(peak(r.u_est), 1e-3, 1.0)};
    spec.distortion.settle = kHarmonicSettle;
    spec.distortion.measure = kHarmonicMeasure;
    spec.distortion.max_order = 3;
  }
  progress.span(kExcitationShare, 0.95);
  spec.progress = [&](const std::string& stage, double f) { progress.at(f, "analysis: " + stage); };
  std::optional<models::TrainingHistory> given =
      models::training_history_from_json(json{{"meta", file.value("meta", json::object())}}, "model " + model_id);
  const models::ModelAnalysis a = models::analyze_model(model, part.u, part.y, spec, std::move(given));

  progress.span(0.95, 1.0);
  json plots = {{"fit", fit_plot(a.y, a.y_sim, env.fs, a.init)},
                {"spectrum", spectrum_plot(a.frf.frequency, a.frf.measured, a.frf.model)}};
  if (a.history) {
    std::vector<HistoryPoint> history;
    for (const auto& p : a.history->points) history.push_back({p.iteration, p.j_est_pct, p.j_val_pct});
    plots["history"] = history_plot(history);
  }
  if (a.distortion && model.kind() == "narx") plots["harmonics"] = harmonics_plot(*a.distortion);
  const double j_est = part.validation ? simulation_j(model, r.u_est, r.y_est) : a.j_sim_pct;
  const double j_val = part.validation ? a.j_sim_pct : kNaN;
  json summary = models::analysis_to_json(a);
  summary["model"] = model_id;
  summary["data"] = data.source + (part.validation ? " (validation)" : " (estimation)");
  progress.at(1.0, "done");
  return {{"j_est_pct", j_est}, {"j_val_pct", finite_or_null(j_val)}, {"summary", summary}, {"plots", plots}};
}

json diagnose_work(const json& params, const JobEnvironment& env, JobControl& control) {
  Progress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  const ExcitationRecord& r = data.record;
  // The simulation diagnosed: a stored linear or NARX model, or (without one) the best linear OE model.
  std::optional<models::AnyModel> baseline;
  if (params.contains("baseline_model") && params.at("baseline_model").is_string()) {
    baseline = models::model_from_json(stored_model_file(env, params.at("baseline_model").get<std::string>()));
  }
  models::DiagnosisOptions options;
  options.init = kInit;
  options.max_findings = params.at("max_findings").get<int>();
  int stages = 0;
  progress.span(kExcitationShare, 0.95);
  // The diagnosis names its stages but not how many remain: each one closes part of the gap to the end.
  options.progress = [&](const std::string& stage) { progress.at(1.0 - std::pow(0.8, ++stages), "diagnose: " + stage); };
  const auto* narx = baseline ? std::get_if<models::NarxModel>(&baseline->model) : nullptr;
  const models::Diagnosis d =
      narx != nullptr
          ? models::diagnose(r.u_est, r.y_est, r.u_val, r.y_val, env.fs, models::narx_baseline(*narx), options)
          : models::diagnose(r.u_est, r.y_est, r.u_val, r.y_val, env.fs,
                             baseline ? std::optional(std::get<models::LinearModel>(baseline->model)) : std::nullopt,
                             options);

  progress.span(0.95, 1.0);
  json report = models::diagnosis_to_json(d);
  report["fs"] = env.fs;
  report["data"] = data.source;
  report["j_val_pct"] = d.j_val_after_pct;
  const Eigen::Index init = std::min<Eigen::Index>(kInit, r.u_val.size() / 10);
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

using KindWork = json (*)(const json&, const JobEnvironment&, JobControl&);

KindWork work_of(const std::string& kind) {
  if (kind == "excite") return excite_work;
  if (kind == "identify-linear") return identify_linear_work;
  if (kind == "identify-narx") return identify_narx_work;
  if (kind == "design-lq") return design_lq_work;
  if (kind == "design-nn") return design_nn_work;
  if (kind == "evaluate") return evaluate_work;
  if (kind == "analyze") return analyze_work;
  if (kind == "diagnose") return diagnose_work;
  return nullptr;
}

std::string expected_kinds() {
  std::string text;
  for (const std::string& k : job_kinds()) text += (text.empty() ? "" : ", ") + k;
  return text;
}

[[noreturn]] void unknown_kind(const std::string& kind) {
  throw std::invalid_argument("kind: unknown job kind \"" + kind + "\"; expected one of " + expected_kinds());
}

}  // namespace

const std::vector<std::string>& job_kinds() {
  static const std::vector<std::string> kinds{"excite", "identify-linear", "identify-narx", "design-lq",
                                              "design-nn", "evaluate", "analyze", "diagnose"};
  return kinds;
}

json validate_job_params(const std::string& kind, const json& params, const JobEnvironment& env) {
  if (work_of(kind) == nullptr) unknown_kind(kind);
  return validate_kind_params(kind, params, env);
}

JobWork job_work(const std::string& kind, const JobEnvironment& env) {
  const KindWork work = work_of(kind);
  if (work == nullptr) unknown_kind(kind);
  return [work, env](const json& params, JobControl& control) { return without_non_finite(work(params, env, control)); };
}

}  // namespace panelbass::api

#include "usecases/design_lq.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <variant>

#include "dsp/decibels.h"
#include "dsp/frequency_grid.h"
#include "models/control/lq_weight_search.h"
#include "models/io/number_text.h"
#include "models/io/roots_json.h"
#include "models/kinds/model_file.h"
#include "models/linear/frequency_response.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

using models::number_text;
using nlohmann::json;

// The ripple of a response is judged from this frequency up when the band-pass has no low corner: a
// transducer's acceleration response falls to zero at DC, and 20 Hz is the lowest audible frequency.
constexpr double kLowestAudibleHz = 20.0;

// The program levels the report gives the drive and excursion at.
constexpr double kReportLevels[] = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0};

// 20·log10|H| of `ss` at each of `f` (Hz).
Eigen::VectorXd magnitude_db(const models::StateSpace& ss, const Eigen::VectorXd& f, double fs) {
  return dsp::magnitude_db(models::frequency_response(ss, f, fs));
}

// Largest minus smallest magnitude (dB) of `ss` over [lo, hi] Hz.
double ripple_db(const models::StateSpace& ss, double lo, double hi, double fs) {
  const Eigen::VectorXd db = magnitude_db(ss, dsp::log_spaced(lo, hi, 400), fs);
  return db.maxCoeff() - db.minCoeff();
}

json array_of(const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

// The target band's figures and how far the controlled response is from it over [corner, band top], dB.
json target_json(const models::LqFeedforward& ff, double hi) {
  const models::LqTarget& t = ff.target;
  json target = {{"highpass_hz", t.band.highpass_hz}, {"order", t.band.order}, {"mid_hz", t.band.mid_hz},
                 {"gain", t.gain},                    {"delay", t.delay}};
  const Eigen::VectorXd f = dsp::log_spaced(t.band.highpass_hz, hi, 400);
  const Eigen::VectorXd off = magnitude_db(ff.desired(), f, ff.fs) - magnitude_db(t.model, f, ff.fs);
  Eigen::Index worst = 0;
  off.cwiseAbs().maxCoeff(&worst);
  target["deviation_db"] = {{"band", {t.band.highpass_hz, hi}}, {"max", std::abs(off[worst])}, {"at_hz", f[worst]},
                            {"at_mid", off[f.size() / 2]}};
  return target;
}

}  // namespace

void check(const DesignLqRequest& q) {
  if (q.r && q.max_input) throw RequestError("max_input", "choose the weight by r or by max_input, not both");
  if (q.r && !(std::isfinite(*q.r) && *q.r > 0.0)) throw RequestError("r", "must be > 0, got " + number_text(*q.r));
  if (q.max_input && !(*q.max_input > 0.0 && *q.max_input <= 1.0)) {
    throw RequestError("max_input", "must be within (0, 1], got " + number_text(*q.max_input));
  }
  if (!(std::isfinite(q.r0) && q.r0 >= 0.0)) throw RequestError("r0", "must be ≥ 0, got " + number_text(q.r0));
  if (q.target_highpass) {
    if (q.max_input) throw RequestError("target_highpass", "a target band and max_input do not go together");
    if (!(q.target_highpass->hz > 0.0 && q.target_highpass->hz < q.band_pass.high_hz)) {
      throw RequestError("target_highpass.hz", "must be within (0, " + number_text(q.band_pass.high_hz) +
                                                   ") Hz, below the band-pass's top, got " + number_text(q.target_highpass->hz));
    }
    if (q.target_highpass->order < 1 || q.target_highpass->order > 8) {
      throw RequestError("target_highpass.order", "must be within 1..8, got " + std::to_string(q.target_highpass->order));
    }
  }
  if (q.noise_samples < 1 || q.noise_samples > 100'000'000) {
    throw RequestError("noise_samples", "must be within 1..100000000, got " + std::to_string(q.noise_samples));
  }
}

json to_json(const DesignLqRequest& q) {
  json j = {{"plant_model", q.plant_name},
            {"r", q.r ? json(*q.r) : json(nullptr)},
            {"max_input", q.max_input ? json(*q.max_input) : json(nullptr)},
            {"r0", q.r0},
            {"band_pass", to_json(q.band_pass)},
            {"target_highpass", nullptr},
            {"noise_samples", q.noise_samples},
            {"seed", q.seed}};
  if (q.target_highpass) j["target_highpass"] = {{"hz", q.target_highpass->hz}, {"order", q.target_highpass->order}};
  return j;
}

models::LinearModel lq_plant_model(const json& file, const std::string& field) {
  try {
    const models::ModelKind& kind = models::model_kind_of(file);
    models::require_role(kind, models::ModelRole::plant, "the model");
    const std::string name = kind.name;
    if (name == "linear") return models::linear_model_from_json(file);
    if (name == "gray_box") return models::gray_box_model_from_json(file).augmented.linear;
    if (name == "ss") {
      const models::SsModel ss = models::ss_model_from_json(file);
      models::LinearModel linear;
      linear.tf = models::to_transfer_function(ss.linearization());
      linear.fs = ss.fs;
      linear.scaling = ss.scaling;
      linear.method = "ss-linearization";
      return linear;
    }
    throw models::ConfigError(std::string("the model is ") + kind.in_words + " (kind " + kind.name +
                              "): design lq takes a linear, gray_box or ss model (linearised at rest)");
  } catch (const RequestError&) {
    throw;
  } catch (const std::exception& e) {
    throw RequestError(field, e.what());
  }
}

DesignLqReport design_lq(const DesignLqRequest& q, Progress& progress) {
  check(q);
  progress.report(0.0, "reading the plant model " + q.plant_name);
  const models::LinearModel model = lq_plant_model(q.plant_model, "plant_model");
  const std::vector<dsp::Biquad> band = q.band_pass.sections("band_pass", model.fs);
  const double lo = q.band_pass.low_hz, hi = q.band_pass.high_hz;
  const Eigen::Index samples = q.noise_samples;

  DesignLqReport report;
  models::LqFeedforward& ff = report.controller;
  models::InputLimits limits;
  json search = nullptr;
  const models::LqWeights weights{q.r.value_or(models::LqWeights{}.R), q.r0};
  if (q.target_highpass) {
    // The target's gain is the model's at the geometric middle of the corner and the band's top.
    progress.report(0.1, "LQ design towards the target band, R = " + number_text(weights.R, 4));
    try {
      ff = models::design_lq(model, weights, {q.target_highpass->hz, q.target_highpass->order, std::sqrt(q.target_highpass->hz * hi)});
    } catch (const std::invalid_argument& e) {
      throw RequestError("target_highpass", e.what());
    }
    progress.report(0.4, "largest safe program amplitude");
    limits = models::max_input(ff, band, samples, q.seed);
  } else if (q.max_input) {
    progress.report(0.1, "searching R for a safe program amplitude of " + number_text(*q.max_input, 4));
    models::LqWeightSearch found = models::design_lq_for_input(model, q.r0, *q.max_input, band, samples, q.seed);
    ff = std::move(found.ff);
    limits = found.limits;
    search = models::lq_weight_search_report(found);
    if (found.at_lower_bound) {
      report.warnings.push_back("the target " + number_text(*q.max_input, 4) + " is met even at R = " +
                                number_text(models::kMinSearchR) + ", the cheapest control searched");
    }
  } else {
    progress.report(0.1, "LQ design, R = " + number_text(weights.R, 4));
    ff = models::design_lq(model, weights);
    progress.report(0.4, "largest safe program amplitude");
    limits = models::max_input(ff, band, samples, q.seed);
  }
  progress.report(0.7, "the design's figures");
  const double R = ff.weights.R;
  const models::DrivePeak peak = models::drive_peak(ff, band);
  if (lo > 0.0 && peak.frequency_hz < lo) {
    char text[400];
    std::snprintf(text, sizeof text,
                  "the drive's gain peaks at %.1f Hz (%+.1f dB), below the band-pass corner %g Hz: the controller boosts "
                  "what the band-pass is there to remove, and max_input falls with it; raise the corner or the band-pass "
                  "order, or the weight (r, max_input)",
                  peak.frequency_hz, peak.gain_db, lo);
    report.warnings.emplace_back(text);
  }
  if (limits.noise < 1.0) {
    report.warnings.push_back("a band-limited noise program above peak " + number_text(limits.noise, 3) +
                              " needs more drive than [-1, 1] gives (the drive's peak at level 1 is " +
                              number_text(1.0 / limits.noise, 3) + ")");
  }
  const double ripple_lo = std::max(lo, kLowestAudibleHz);
  ff.meta = {{"model", q.plant_name},
             {"model_method", model.method},
             {"order", ff.plant.order()},
             {"weights", {{"R", R}, {"R0", q.r0}}},
             {"bandpass", {lo, hi}},
             {"bandpass_order", q.band_pass.order},
             {"max_input", {{"worst", limits.worst}, {"noise", limits.noise}, {"samples", samples}, {"seed", q.seed}}}};
  if (!search.is_null()) ff.meta["R_search"] = search;
  json target = nullptr;
  if (ff.has_target()) {
    target = target_json(ff, hi);
    ff.meta["target"] = target;
  }

  // Per program level: the noise's peak drive and estimated excursion scale with it (a linear model).
  const double unit_excursion = models::noise_excursion(ff, band, samples, q.seed);
  json levels = json::array();
  for (const double level : kReportLevels) {
    const double drive = level / limits.noise;
    levels.push_back({{"level", level}, {"drive_peak", drive}, {"drive_within_limits", drive <= 1.0},
                      {"excursion_peak", level * unit_excursion}});
  }
  const Eigen::VectorXcd poles = ff.poles();
  report.summary = {
      {"plant_model", q.plant_name},
      {"fs", ff.fs},
      {"order", ff.plant.order()},
      {"R", R},
      {"R_search", search},
      {"R0", q.r0},
      {"L", array_of(ff.L.transpose())},
      {"poles", models::roots_json(poles)},
      {"zeros", models::roots_json(ff.zeros())},
      {"pole_radius", poles.size() ? poles.cwiseAbs().maxCoeff() : 0.0},
      {"bandpass", {lo, hi}},
      {"bandpass_order", q.band_pass.order},
      {"max_input_worst", limits.worst},
      {"max_input_noise", limits.noise},
      {"safe_amplitude", limits.noise},
      {"target", target},
      {"levels", levels},
      {"excursion",
       {{"estimate", "the desired response y_lin (the model's output, acceleration) to the band-passed noise, integrated "
                     "twice by a leaky integrator (corner fs/500)"},
        {"unit", "model output x s^2 (sensor volts: divide by its V/(m/s^2) for metres)"}}},
      {"noise_samples", samples},
      {"drive_peak", {{"frequency_hz", peak.frequency_hz}, {"gain_db", peak.gain_db}}},
      {"unity_gain_hz", models::unity_gain_hz(ff)},
      {"seed", q.seed},
      {"ripple_db",
       {{"band", {ripple_lo, hi}},
        {"model", ripple_db(ff.plant, ripple_lo, hi, ff.fs)},
        {"controlled", ripple_db(ff.desired(), ripple_lo, hi, ff.fs)}}}};
  const Eigen::VectorXd f = dsp::log_spaced(10.0, 0.49 * ff.fs, 200);
  report.spectrum = {{"f", array_of(f)},
                     {"plant_db", array_of(magnitude_db(ff.plant, f, ff.fs))},
                     {"controlled_db", array_of(magnitude_db(ff.desired(), f, ff.fs))},
                     {"controller_db", array_of(magnitude_db(ff.controller(), f, ff.fs))}};
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases

#include "usecases/tune.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "dsp/excitation.h"
#include "models/control/mirror_friction_refit.h"
#include "models/io/number_text.h"
#include "usecases/request_error.h"
#include "usecases/verify.h"

namespace panelbass::usecases {
namespace {

using models::number_text;
using Clock = std::chrono::steady_clock;

// A cut below this at any verified point leaves the filter out, dB: within the readings' own uncertainty of 0.
constexpr double kWorstAllowedCutDb = -1.0;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The decision when nothing measures the cut: the filter is the model's, kept on its current J (`why`: what hid it).
void keep_unverified(const std::string& why, const DesignMirrorReport& mirror, TuneReport& report) {
  report.keep = true;
  report.decision = "kept without verification: " + why + ", so the cut is not measured (the model follows the coil "
                    "current to " + number_text(mirror.summary.at("current_j_val_pct").get<double>(), 3) +
                    " % J on validation); listen with PUT /api/program and the feedforward bypass";
}

// The tune's decision on a verification: keep when it cuts by keep_min_cut_db somewhere and worsens nowhere; when
// every reachable level has the transducer alone at the sensor's noise floor (a displacement sensor hears little
// distortion), kept unverified as without a sensor.
void decide(const EqualOutputReport& v, double keep_min_cut_db, const DesignMirrorReport& mirror, TuneReport& report) {
  std::optional<double> best, worst;
  std::string worst_at;
  int credited = 0, reachable = 0;
  for (const EqualOutputPoint& p : v.points) {
    if (!p.reachable) continue;
    ++reachable;
    const std::optional<double> cut = EqualOutputReport::credited_cut(p);
    if (!cut) continue;
    ++credited;
    best = best ? std::max(*best, *cut) : *cut;
    if (!worst || *cut < *worst) {
      worst = *cut;
      worst_at = number_text(p.frequency_hz) + " Hz, program level " + number_text(p.program_level);
    }
  }
  if (credited == 0 && reachable > 0) {
    keep_unverified("at every reachable probe level the transducer alone is at the sensor's noise floor", mirror, report);
    report.warnings.push_back("verify: the sensor hears no distortion above its noise floor at any level");
  } else if (credited == 0) {
    report.keep = false;
    report.decision = "left out: no probe level is reachable with the chain's limiter untouched";
  } else if (*worst < kWorstAllowedCutDb) {
    report.keep = false;
    report.decision = "left out: it makes the distortion worse at " + worst_at + " (" + number_text(*worst, 3) + " dB at equal output)";
  } else if (*best < keep_min_cut_db) {
    report.keep = false;
    report.decision = "left out: its best cut is " + number_text(*best, 3) + " dB, less than " + number_text(keep_min_cut_db) + " dB";
  } else {
    report.keep = true;
    report.decision = "kept: it cuts the THD by " + number_text(*worst, 3) + " to " + number_text(*best, 3) +
                      " dB at equal output over the " + std::to_string(credited) + (credited == 1 ? " level" : " levels") + " verified";
  }
}

// The refine step's sines: at a quarter and half the fitted resonance (the motion stiffness-controlled, small beside
// the friction's transition), each settled for kRefineSettleSeconds and measured for kRefineMeasureSeconds.
constexpr double kRefineSettleSeconds = 0.5;
constexpr double kRefineMeasureSeconds = 1.5;
constexpr double kRefineLowestHz = 5.0;

// Plays the refine step's sines through `play`, refits the friction's velocity scale of `mirror`'s model on the
// current's harmonics (models::refit_friction_scale) and keeps the refit when it matches them better; on quiet sines
// without a sensor in the fit, searches the eddy-current branch there too (models::search_eddy_branch). `fit` is the
// fit's request with the drive it chose (`from_loopback`: the loopback, which the sines are then read by as well).
void refine_friction(const TuneRequest& q, const PlayFunction& play, const DesignMirrorRequest& fit, bool from_loopback,
                     DesignMirrorReport& mirror, TuneReport& report, Progress& progress) {
  const Clock::time_point start = Clock::now();
  const double fs = q.chain.fs;
  const double resonance = mirror.summary.at("resonance_hz").get<double>();
  const double level = std::min(*std::min_element(q.verify.levels.begin(), q.verify.levels.end()), q.safe_level);
  dsp::SteppedSineSpec spec;
  spec.fs = fs;
  spec.amplitude = level;
  spec.frequencies = {std::max(resonance / 4.0, kRefineLowestHz), std::max(resonance / 2.0, kRefineLowestHz)};
  spec.settle = static_cast<std::size_t>(std::llround(kRefineSettleSeconds * fs));
  spec.measure = static_cast<std::size_t>(std::llround(kRefineMeasureSeconds * fs));
  const dsp::SteppedSine sines = dsp::stepped_sine(spec);
  progress.report(0.4, "refining the friction: sines at " + number_text(sines.steps[0].frequency, 3) + " and " +
                           number_text(sines.steps[1].frequency, 3) + " Hz, level " + number_text(level));
  const Playback played = play(sines.signal);
  if (played.current.size() != sines.signal.size()) throw std::runtime_error("refine: the backend recorded no coil current");
  models::CurrentSineRecord record;
  if (from_loopback && played.loopback.size() != sines.signal.size()) throw std::runtime_error("refine: the backend recorded no loopback");
  record.drive = from_loopback ? played.loopback : sines.signal;  // the fit's drive (step 2)
  record.current = played.current;
  record.steps = sines.steps;
  nlohmann::json frequencies = nlohmann::json::array();
  for (const dsp::SineStep& step : sines.steps) frequencies.push_back(step.frequency);
  models::FrictionScaleRefit refit;
  try {
    refit = models::refit_friction_scale(mirror.model, mirror.summary.at("current_lag").get<int>(), record, fs);
  } catch (const std::invalid_argument& e) {  // a record it cannot read: the fit's v0 stays, and the step says why
    report.warnings.push_back(std::string("refine: skipped, ") + e.what());
    report.steps.push_back({"refine", seconds_since(start), {{"frequencies_hz", frequencies}, {"level", level}, {"used", false}, {"error", e.what()}}});
    return;
  }
  if (refit.used) {
    mirror.model = refit.model;
    mirror.summary["friction_velocity_mm_per_s"] = refit.model.friction_velocity;
    mirror.meta["friction_velocity_refit"] = refit.scale;
  }
  nlohmann::json summary = {{"frequencies_hz", frequencies},
                            {"level", level},
                            {"used", refit.used},
                            {"friction_velocity_scale", refit.scale},
                            {"harmonic_error_before", refit.error_before},
                            {"harmonic_error_after", refit.error_after},
                            {"current_harmonics_rms", refit.harmonics_rms}};
  if (q.sensor_kind == "none" && level <= models::kEddySearchLargestLevel) {
    // the eddy-current branch, judged on the same sines when they are quiet (the multisine fit continued with each
    // branch tried)
    const models::EddyBranchSearch eddy = models::search_eddy_branch(
        mirror.model, mirror.summary.at("current_lag").get<int>(), fit.drive, fit.current, record, fs);
    nlohmann::json trials = nlohmann::json::array();
    for (const models::EddyBranchTrial& t : eddy.trials) {
      trials.push_back({t.branch.resistance / mirror.model.electrical[4], t.branch.rate, t.current_j_val_pct, t.harmonic_error});
    }
    summary["eddy"] = {{"used", eddy.used}, {"harmonic_error_without", eddy.error_without},
                       {"harmonic_error_with", eddy.error_with}, {"trials", trials}};
    if (eddy.used) {
      mirror.model = eddy.model;
      mirror.summary["eddy"] = {{"resistance", eddy.model.eddy.resistance}, {"rate", eddy.model.eddy.rate}};
      mirror.summary["current_j_val_pct"] = eddy.current_j_val_pct;
      mirror.summary["friction_velocity_mm_per_s"] = eddy.model.friction_velocity;
    }
  }
  report.steps.push_back({"refine", seconds_since(start), summary});
}

// The fit and the drive it read.
struct ChosenFit {
  DesignMirrorReport mirror;
  bool from_loopback = false;
};

// Fits `fit` from the drive as sent and, when the backend looped it back (`loopback` as long as it), from the loopback,
// and keeps the model that follows the current better on validation; `fit.drive` is left the chosen one, and the
// summary says which (`drive`) and both J's (`current_j_val_pct_by_drive`). Neither drive wins everywhere (through the
// JACK dummy, current J_val % as sent / loopback: second-exciter 0.00019 / 0.0011, its 80 Hz cut 19–25 / 7–9 dB;
// panel-exciter 0.0089 / 0.0044, 80 Hz 30–31 / 37–49 dB): the loopback carries its own capture path's errors into the
// model's input, the drive as sent leaves the converters' response to the model's three drive taps.
ChosenFit fit_from_better_drive(DesignMirrorRequest& fit, const Eigen::VectorXd& drive, const Eigen::VectorXd& loopback,
                                Progress& progress) {
  const bool looped = loopback.size() == drive.size();
  const auto fit_from = [&](const Eigen::VectorXd& d, double from, double to) {
    fit.drive = d;
    ProgressSpan fit_progress(progress, from, to);
    return design_mirror(fit, fit_progress);
  };
  const auto current_j_val = [](const DesignMirrorReport& r) {
    return r.usable ? r.summary.at("current_j_val_pct").get<double>() : std::numeric_limits<double>::infinity();
  };
  ChosenFit chosen{fit_from(drive, 0.3, looped ? 0.35 : 0.4)};
  nlohmann::json drives = {{"as sent", current_j_val(chosen.mirror)}};
  if (looped) {
    DesignMirrorReport other = fit_from(loopback, 0.35, 0.4);
    drives["loopback"] = current_j_val(other);
    if (current_j_val(other) < current_j_val(chosen.mirror)) chosen = {std::move(other), true};
  }
  fit.drive = chosen.from_loopback ? loopback : drive;
  chosen.mirror.summary["drive"] = chosen.from_loopback ? "loopback" : "as sent";
  chosen.mirror.summary["current_j_val_pct_by_drive"] = drives;
  return chosen;
}

}  // namespace

void check(const TuneRequest& q) {
  const double fs = q.chain.fs;
  if (!(q.safe_level > 0.0 && q.safe_level <= 1.0)) throw RequestError("safe_level", "must be within (0, 1]");
  if (q.samples < 3000 || q.samples > 1'000'000) throw RequestError("samples", "must be within 3000..1000000, got " + std::to_string(q.samples));
  if (!(q.amplitude > 0.0 && q.amplitude <= q.safe_level)) {
    throw RequestError("amplitude", "must be within (0, safe level " + number_text(q.safe_level) + "], got " + number_text(q.amplitude));
  }
  if (!(q.f_min >= 0.0 && q.f_min < q.f_max)) throw RequestError("f_min", "must be ≥ 0 and below f_max");
  if (!(q.f_max < fs / 2.0)) throw RequestError("f_max", "must be below fs/2 = " + number_text(fs / 2.0) + " Hz");
  if (q.max_delay < 0 || q.max_delay > 64) throw RequestError("max_delay", "must be within 0..64");
  if (!(std::isfinite(q.keep_min_cut_db) && q.keep_min_cut_db >= 0.0)) throw RequestError("keep_min_cut_db", "must be ≥ 0");
  check(q.verify, fs);
  DesignMirrorRequest fit;  // the fit's own checks on a stand-in record of the right shape
  fit.fs = fs;
  fit.current_only = true;
  fit.sensor_kind = q.sensor_kind;
  fit.max_delay = q.max_delay;
  fit.drive = fit.current = fit.sensor = Eigen::VectorXd::Zero(1000);
  check(fit);
}

nlohmann::json to_json(const TuneRequest& q) {
  nlohmann::json fields = to_json(q.verify);  // the probes, as the verify job names them
  fields.update({{"samples", q.samples},     {"amplitude", q.amplitude},     {"f_min", q.f_min},
                 {"f_max", q.f_max},         {"seed", q.seed},               {"sensor_kind", q.sensor_kind},
                 {"max_delay", q.max_delay}, {"keep_min_cut_db", q.keep_min_cut_db}, {"refine_friction", q.refine_friction}});
  return fields;
}

nlohmann::json TuneReport::to_json() const {
  nlohmann::json steps_json = nlohmann::json::array();
  for (const TuneStep& s : steps) steps_json.push_back({{"name", s.name}, {"seconds", s.seconds}, {"summary", s.summary}});
  return {{"steps", steps_json},
          {"keep", keep},
          {"decision", decision},
          {"verify", verify ? verify->to_json() : nlohmann::json(nullptr)},
          {"warnings", warnings},
          {"left_out", left_out}};
}

TuneReport tune(const TuneRequest& q, const PlayFunction& play, Progress& progress) {
  check(q);
  const double fs = q.chain.fs;
  TuneReport report;
  // 1. Measure: a multisine over the working band; the drive as the converters delivered it and the current.
  Clock::time_point start = Clock::now();
  progress.report(0.0, "measuring: a " + number_text(q.f_min) + "-" + number_text(q.f_max) + " Hz multisine");
  dsp::MultisineSpec spec;
  spec.period = static_cast<std::size_t>(q.samples);
  spec.fs = fs;
  spec.f_min = q.f_min;
  spec.f_max = q.f_max;
  spec.amplitude = q.amplitude;
  spec.seed = q.seed;
  const Eigen::VectorXd drive = dsp::multisine(spec).signal;
  const Playback record = play(drive);
  if (record.current.size() != drive.size()) {
    throw std::runtime_error("measure: the backend records no coil current, and the mirror filter is fitted from it "
                             "(on a sound card: a capture channel with the current, serve --current-channel)");
  }
  const bool sensed = record.sensor.size() == drive.size();
  if (!sensed && q.sensor_kind != "none") {
    throw std::runtime_error("measure: sensor_kind \"" + q.sensor_kind + "\" asks the fit to read a sensor the backend does not record");
  }
  const bool looped = record.loopback.size() == drive.size();
  report.steps.push_back({"measure", seconds_since(start),
                          {{"samples", drive.size()}, {"seconds", static_cast<double>(drive.size()) / fs},
                           {"amplitude", q.amplitude}, {"band_hz", {q.f_min, q.f_max}},
                           {"loopback", looped},
                           {"current_rms_a", std::sqrt(record.current.squaredNorm() / static_cast<double>(drive.size()))}}});
  report.drive = drive;
  report.measurement = record;
  // 2. The gray-box model from the current (and the sensor when asked), and its mirror filter.
  start = Clock::now();
  DesignMirrorRequest fit;
  fit.current = record.current;
  fit.sensor = record.sensor;
  fit.current_only = true;
  fit.sensor_kind = q.sensor_kind;
  fit.fs = fs;
  fit.max_delay = q.max_delay;
  fit.data_name = "tune's multisine (" + number_text(q.f_min) + "-" + number_text(q.f_max) + " Hz, peak " +
                  number_text(q.amplitude) + ", seed " + std::to_string(q.seed) + ")";
  ChosenFit chosen = fit_from_better_drive(fit, drive, record.loopback, progress);
  DesignMirrorReport& mirror = chosen.mirror;
  report.steps.push_back({"fit", seconds_since(start), mirror.summary});
  for (const std::string& w : mirror.warnings) report.warnings.push_back("fit: " + w);
  if (!mirror.usable) {
    std::string why;
    for (const std::string& w : mirror.warnings) why += (why.empty() ? "" : " ") + w;
    throw std::runtime_error("fit: the model misses this transducer, so no mirror filter is made: " + why);
  }
  // 3. The friction's velocity scale from the current's harmonics where it shows: quiet sines below the resonance.
  if (q.refine_friction) refine_friction(q, play, fit, chosen.from_loopback, mirror, report, progress);
  if (sensed) {
    // 4. Verify the chain with the filter at equal output level.
    start = Clock::now();
    VerifyRequest v;  // the verify verb's request: the filter in the feedforward slot of the engine's chain
    v.feedforward_model = models::mirror_model_to_json(mirror.model, mirror.meta);
    v.feedforward_name = "the tune's mirror filter";
    v.chain = q.chain;
    v.safe_level = q.safe_level;
    v.settings = q.verify;
    ProgressSpan verify_progress(progress, 0.45, 0.98);
    EqualOutputReport verified = verify(v, play, verify_progress);
    for (const std::string& w : verified.warnings) report.warnings.push_back("verify: " + w);
    report.steps.push_back({"verify", seconds_since(start), {{"plays", verified.plays}, {"worst_cut_db", verified.to_json()["worst_cut_db"]}}});
    // 5. Keep it only where it helps.
    decide(verified, q.keep_min_cut_db, mirror, report);
    report.verify = std::move(verified);
  } else {
    // Klippel's current-only configuration: nothing hears the output, so the cut cannot be measured; the filter is
    // the model's (its current J said it follows the transducer) and joins the chain on that.
    keep_unverified("the backend records no sensor", mirror, report);
    report.warnings.push_back("verify: skipped, the backend records no sensor to read the THD from");
  }
  report.steps.push_back({"decide", 0.0, {{"keep", report.keep}, {"decision", report.decision}}});
  report.left_out = {
      "an LQ feedforward: the feedforward slot holds one controller, and the LQ flattens the response without "
      "cutting the distortion (design-lq, then verify it against this filter, if a flat response matters more)",
      "a neural feedback: it needs a NARX model of the transducer behind this filter (design-nn; verify shows whether "
      "it cuts more on top of it)"};
  report.mirror = std::move(mirror);
  progress.report(1.0, report.decision);
  return report;
}

}  // namespace panelbass::usecases

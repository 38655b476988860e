#include "usecases/excite.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "dsp/excitation.h"
#include "models/control/lq_feedforward.h"
#include "models/io/number_text.h"
#include "usecases/band_pass.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

using models::number_text;

// RMS over both parts of a record.
double rms_of_parts(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::Index n = a.size() + b.size();
  return n > 0 ? std::sqrt((a.squaredNorm() + b.squaredNorm()) / static_cast<double>(n)) : 0.0;
}

// Plays `drive`; the sensor must come back as long and finite. A card's calibration report joins `record.card`.
Playback play_part(const PlayFunction& play, const Eigen::VectorXd& drive, ExcitationRecord& record) {
  Playback p = play(drive);
  if (p.sensor.size() == 0) {
    throw std::runtime_error("the backend records no sensor, and a measurement reads one (a sound card: --sensor-channel)");
  }
  if (p.sensor.size() != drive.size()) {
    throw std::runtime_error("the backend recorded " + std::to_string(p.sensor.size()) + " samples for a drive of " +
                             std::to_string(drive.size()));
  }
  if (!p.sensor.allFinite()) throw std::runtime_error("the backend recorded a non-finite response");
  if (!p.report.is_null()) {
    if (record.card.is_null()) record.card = nlohmann::json::array();
    record.card.push_back(p.report);
  }
  return p;
}

}  // namespace

void check(const ExciteRequest& q) {
  if (q.signal != "noise" && q.signal != "multisine" && q.signal != "control") {
    throw RequestError("signal", "must be one of \"noise\", \"multisine\", \"control\", got \"" + q.signal + "\"");
  }
  const std::string range = "[" + std::to_string(kMinRecordSamples) + ", " + std::to_string(kMaxRecordSamples) + "]";
  if (q.samples < kMinRecordSamples || q.samples > kMaxRecordSamples) {
    throw RequestError("samples", "must be an integer in " + range + ", got " + std::to_string(q.samples));
  }
  if (q.validation_samples < 0 || q.validation_samples > kMaxRecordSamples) {
    throw RequestError("validation_samples", "must be an integer in [0, " + std::to_string(kMaxRecordSamples) + "], got " +
                                                 std::to_string(q.validation_samples));
  }
  if (q.validation_samples > 0 && q.validation_samples < kMinRecordSamples) {
    throw RequestError("validation_samples", "must be 0 (none) or at least " + std::to_string(kMinRecordSamples) +
                                                 ", got " + std::to_string(q.validation_samples));
  }
  if (!(std::isfinite(q.fs) && q.fs > 0.0)) throw RequestError("fs", "must be > 0 Hz, got " + number_text(q.fs));
  if (!(q.safe_level > 0.0 && q.safe_level <= 1.0)) throw RequestError("safe_level", "must be within (0, 1]");
  if (!(std::isfinite(q.amplitude) && q.amplitude > 0.0 && q.amplitude <= 1.0)) {
    throw RequestError("amplitude", "must be a number in (0, 1], got " + number_text(q.amplitude));
  }
  if (q.signal != "control" && q.amplitude > q.safe_level) {
    throw RequestError("amplitude", "exceeds the sound card's safe level " + number_text(q.safe_level) +
                                        " (--safe-level), got " + number_text(q.amplitude));
  }
  if (q.signal != "control") return;
  const auto control_min = static_cast<long long>(models::kMinControlSamples);
  if (q.samples < control_min) {
    throw RequestError("samples", "a control excitation needs at least " + std::to_string(control_min) + " samples, got " +
                                      std::to_string(q.samples));
  }
  if (q.validation_samples > 0 && q.validation_samples < control_min) {
    throw RequestError("validation_samples", "must be 0 (none) or at least " + std::to_string(control_min) +
                                                 " for a control excitation, got " + std::to_string(q.validation_samples));
  }
  if (q.feedforward_name.empty()) throw RequestError("feedforward_model", "a control excitation plays an LQ feedforward's drive: required");
  if (!(std::isfinite(q.sine_peak) && q.sine_peak > 0.0 && q.sine_peak <= 1.0)) {
    throw RequestError("sine_peak", "must be a number in (0, 1], got " + number_text(q.sine_peak));
  }
  if (!(std::isfinite(q.program_share) && q.program_share >= 0.0 && q.program_share <= 1.0)) {
    throw RequestError("program_share", "must be a number in [0, 1], got " + number_text(q.program_share));
  }
}

nlohmann::json to_json(const ExciteRequest& q) {
  nlohmann::json fields = {{"signal", q.signal},   {"samples", q.samples}, {"validation_samples", q.validation_samples},
                           {"amplitude", q.amplitude}, {"seed", q.seed}};
  if (q.signal == "control" || !q.feedforward_name.empty()) {
    fields.update({{"feedforward_model", q.feedforward_name}, {"sine_peak", q.sine_peak}, {"program_share", q.program_share}});
  }
  return fields;
}

Eigen::VectorXd excitation_signal(const ExciteRequest& q, Eigen::Index samples, std::uint64_t seed) {
  Eigen::VectorXd drive;
  if (q.signal == "multisine") {
    dsp::MultisineSpec spec;
    spec.period = static_cast<std::size_t>(std::min<Eigen::Index>(4096, samples));
    spec.periods = static_cast<std::size_t>((samples + spec.period - 1) / spec.period);
    spec.fs = q.fs;
    spec.f_min = 0.0;
    spec.f_max = q.fs / 2.0;
    spec.amplitude = q.amplitude;
    spec.seed = seed;
    drive = dsp::multisine(spec).signal.head(samples);
  } else {
    drive = dsp::uniform_noise(static_cast<std::size_t>(samples), q.amplitude, seed);
  }
  if (!drive.allFinite()) throw std::runtime_error("the excitation has a non-finite sample");
  return drive.cwiseMax(-1.0).cwiseMin(1.0);  // the safety rule
}

ExciteReport excite(const ExciteRequest& q, const PlayFunction& play, Progress& progress) {
  check(q);
  const auto samples = static_cast<Eigen::Index>(q.samples), validation = static_cast<Eigen::Index>(q.validation_samples);
  const double total = static_cast<double>(samples + validation);
  ExciteReport report;
  ExcitationRecord& r = report.record;
  progress.report(0.0, "excitation: " + std::to_string(samples) + " samples of " + q.signal);
  if (q.signal == "control") {
    // The plant in its operating regime (panelbass simulate --signal control): the LQ feedforward's output for the
    // controller design's program, noise then stepped sines, with per-sample harmonic weights.
    models::LqFeedforward ff;
    try {
      ff = models::lq_feedforward_from_json(q.feedforward_model);
    } catch (const std::exception& e) {
      throw RequestError("feedforward_model", e.what());
    }
    const std::vector<dsp::Biquad> band_pass = band_pass_of(ff).sections("feedforward_model", ff.fs);
    models::FeedbackDesignOptions design;
    design.sine_peak = q.sine_peak;
    design.program_share = q.program_share;
    // One part: the chain's drive for the design's program, played, and its steps' harmonic weights.
    const auto control_part = [&](Eigen::Index n, std::uint64_t part_seed, Eigen::VectorXd& u, Eigen::VectorXd& y,
                                  Eigen::VectorXd& w, Eigen::VectorXd& loopback) {
      design.samples = n;
      const models::ControlRecord part = models::control_record(ff, band_pass, design, part_seed);
      if (!part.u.allFinite()) throw std::runtime_error("the control excitation has a non-finite sample");
      // The safety rule, and on a card its safe level: the controller's drive is clipped to it.
      const double cap = std::min(1.0, q.safe_level);
      u = part.u.cwiseMax(-cap).cwiseMin(cap);
      Playback p = play_part(play, u, r);
      y = std::move(p.sensor);
      loopback = std::move(p.loopback);
      w = models::harmonic_weights(part, y, q.fs);
    };
    control_part(samples, q.seed, r.u_est, r.y_est, r.w_est, r.l_est);
    if (validation > 0) {
      progress.report(samples / total, "excitation: " + std::to_string(validation) + " validation samples");
      control_part(validation, q.seed + 1, r.u_val, r.y_val, r.w_val, r.l_val);
    }
  } else {
    const auto part = [&](Eigen::Index n, std::uint64_t part_seed, Eigen::VectorXd& u, Eigen::VectorXd& y,
                          Eigen::VectorXd& i, Eigen::VectorXd& loopback) {
      u = excitation_signal(q, n, part_seed);
      Playback p = play_part(play, u, r);
      y = std::move(p.sensor);
      i = std::move(p.current);
      loopback = std::move(p.loopback);
    };
    part(samples, q.seed, r.u_est, r.y_est, r.i_est, r.l_est);
    if (validation > 0) {
      progress.report(samples / total, "excitation: " + std::to_string(validation) + " validation samples");
      part(validation, q.seed + 1, r.u_val, r.y_val, r.i_val, r.l_val);
    }
  }
  report.summary = {{"fs", q.fs},
                    {"signal", q.signal},
                    {"amplitude", q.amplitude},
                    {"seed", q.seed},
                    {"samples", r.u_est.size()},
                    {"validation_samples", r.u_val.size()},
                    {"rms_drive", rms_of_parts(r.u_est, r.u_val)},
                    {"rms_response", rms_of_parts(r.y_est, r.y_val)}};
  progress.report(1.0, "excitation recorded");
  return report;
}

}  // namespace panelbass::usecases

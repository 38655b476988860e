#include "dsp/sample_rate.h"
#include "models/control/feedback_design.h"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include "dsp/random.h"
#include "models/control/model_probes.h"
#include "models/linear/state_space.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::models {
namespace {

void require_options(const FeedbackDesignOptions& o, double fs) {
  if (o.samples < kMinControlSamples) {
    throw std::invalid_argument("design nn: samples must be >= " + std::to_string(kMinControlSamples) + ", got " +
                                std::to_string(o.samples));
  }
  if (!(o.sine_share >= 0.0 && o.sine_share <= 1.0)) throw std::invalid_argument("design nn: sine_share must be within [0, 1]");
  if (!(o.sine_low_hz > 0.0 && o.sine_low_hz < o.sine_high_hz && o.sine_high_hz < fs / 2.0)) {
    throw std::invalid_argument("design nn: stepped sines need 0 < low < high < fs/2");
  }
  if (!(o.sine_peak > 0.0 && o.sine_peak <= 1.0)) throw std::invalid_argument("design nn: sine_peak must be within (0, 1]");
  if (!(o.program_share >= 0.0 && o.program_share <= 1.0)) {
    throw std::invalid_argument("design nn: program_share must be within [0, 1]");
  }
  if (!(o.sine_step_seconds * fs >= 20.0)) throw std::invalid_argument("design nn: sine steps must last >= 20 samples");
}

// |band-pass · feedforward| at f Hz.
double chain_gain(const dsp::SosFilter& shape, const StateSpace& controller, double f, double fs) {
  return std::abs(shape.response(f, fs) * response(controller, f, fs));
}

// The largest gain of band-pass + feedforward over [low, high] Hz, on a log grid of 400 frequencies.
double largest_gain(const dsp::SosFilter& shape, const StateSpace& controller, double low, double high, double fs) {
  double largest = 0.0;
  for (int i = 0; i < 400; ++i) {
    largest = std::max(largest, chain_gain(shape, controller, low * std::pow(high / low, i / 399.0), fs));
  }
  return largest;
}

// Stepped sines at log-uniform random frequencies from sample `from` to the end of `program`, each at its
// drive or program level (FeedbackDesignOptions, control_record's comment), faded in and out.
std::vector<SineStep> add_stepped_sines(Eigen::VectorXd& program, Eigen::Index from, const StateSpace& controller,
                                        const std::vector<dsp::Biquad>& band_pass, const FeedbackDesignOptions& o,
                                        double fs, dsp::Rng& rng) {
  const dsp::SosFilter shape(band_pass);
  const auto step = static_cast<Eigen::Index>(o.sine_step_seconds * fs);
  const double program_top = o.sine_peak / largest_gain(shape, controller, o.sine_low_hz, o.sine_high_hz, fs);
  std::vector<SineStep> steps;
  for (Eigen::Index start = from; start < program.size(); start += step) {
    const double f = o.sine_low_hz * std::pow(o.sine_high_hz / o.sine_low_hz, rng.uniform(0.0, 1.0));
    const double gain = chain_gain(shape, controller, f, fs);
    const bool program_level = rng.uniform(0.0, 1.0) < o.program_share;
    // the drive reaches sine_peak, or the program does where the chain's gain is below 1 (near the plant's
    // resonance): the rule `evaluate` sets its probes by, so a step there plays at the probe's drive
    const double drive_level = std::min(o.sine_peak, o.sine_peak / gain);
    const double amplitude = program_level ? std::min(drive_level, program_top * rng.uniform(0.25, 2.0)) : drive_level;
    const Eigen::Index length = std::min(step, program.size() - start);
    // two periods of fade (at least 10 ms, at most a quarter step): a short fade splatters into the band
    // below the pass band's corner, where the feedforward's gain can be far above its gain at f
    const auto fade = std::min<Eigen::Index>(
        static_cast<Eigen::Index>(std::max(0.01 * fs, 2.0 * fs / f)), std::max<Eigen::Index>(1, length / 4));
    for (Eigen::Index k = 0; k < length; ++k) {
      const double edge = static_cast<double>(std::min(k, length - 1 - k));
      const double window = edge < static_cast<double>(fade) ? 0.5 - 0.5 * std::cos(std::numbers::pi * edge / fade) : 1.0;
      program[start + k] = window * amplitude * std::sin(2.0 * std::numbers::pi * f * k / fs);
    }
    steps.push_back({start, length, f, fade});
  }
  return steps;
}

// The steady-state gain sets each step's level; what the feedforward's slow poles carry over from the fades
// and the earlier steps can still lift a step's peak. Steps whose drive passes `peak` are scaled down until
// none does (the chain is linear, so a few passes settle it).
void keep_steps_within_peak(Eigen::VectorXd& program, const std::vector<SineStep>& steps,
                            const StateSpace& controller, const std::vector<dsp::Biquad>& band_pass, double peak) {
  for (int pass = 0; pass < 20; ++pass) {
    const Eigen::VectorXd u = simulate(controller, dsp::SosFilter(band_pass).process(program));
    bool within = true;
    for (const SineStep& s : steps) {
      const double step_peak = u.segment(s.start, s.length).cwiseAbs().maxCoeff();
      if (step_peak <= peak) continue;
      within = false;
      program.segment(s.start, s.length) *= 0.999 * peak / step_peak;
    }
    if (within) return;
  }
}

// The plant-fundamental target: on each step's steady part (from two fades in, so the resonances' transients
// have settled, to its fade out) adds to `y_desired` (the small-signal response) the fundamental and mean of
// what the uncorrected `loop` output departs from it by, so that the change of gain with the level is no
// error and the harmonics are (the feedforward's own transients, in the small-signal response, are none
// either). Returns the steady parts.
std::vector<RecordPart> add_loop_fundamentals(Eigen::VectorXd& y_desired, const Eigen::VectorXd& loop,
                                              const std::vector<SineStep>& steps, double fs) {
  std::vector<RecordPart> steady;
  for (const SineStep& s : steps) {
    const auto [start, length] = steady_part(s);
    if (length < 4) continue;
    // least squares: departure ≈ a·sin(ωk) + b·cos(ωk) + c over the steady part
    Eigen::MatrixXd basis(length, 3);
    for (Eigen::Index k = 0; k < length; ++k) {
      const double phase = 2.0 * std::numbers::pi * s.f * static_cast<double>(start - s.start + k) / fs;
      basis.row(k) << std::sin(phase), std::cos(phase), 1.0;
    }
    const Eigen::VectorXd departure = loop.segment(start, length) - y_desired.segment(start, length);
    const Eigen::Vector3d coefficients = basis.colPivHouseholderQr().solve(departure);
    y_desired.segment(start, length) += basis * coefficients;
    steady.push_back({start, length});
  }
  return steady;
}

// Scales `weight` on each part by (mean power of `weighed` over all parts / its power on that part), capped
// at 10⁴, so that every part weighs in with the record's mean power.
void weigh_parts_by_inverse_power(Eigen::VectorXd& weight, const Eigen::VectorXd& weighed,
                                  const std::vector<RecordPart>& parts) {
  double energy = 0.0, samples = 0.0;
  for (const RecordPart& p : parts) {
    energy += weighed.segment(p.start, p.length).squaredNorm();
    samples += static_cast<double>(p.length);
  }
  const double reference = energy / samples;
  for (const RecordPart& p : parts) {
    const double power = weighed.segment(p.start, p.length).squaredNorm() / static_cast<double>(p.length);
    weight.segment(p.start, p.length) *= power > 0.0 ? std::min(1e4, reference / power) : 1.0;
  }
}

/// Re-aims record `r` at the device (tuning on the device, design_feedback): the uncorrected loop is played
/// into it; on each sine step's steady part long enough for its harmonics the target becomes the fundamental
/// and mean of the device's own output there, counted through its harmonic series alone (returned in
/// `stretches`); the noise part keeps the plant model's target; the rest weighs 0. With distortion weighting
/// every part weighs by the inverse power of the device's departure from its target (on the steps, of its
/// harmonics). Returns the device's output for a drive: the mean of o.device_playbacks playbacks, each with
/// its own sensor noise (seeded noise_seed + i·kPlaybackSeedStride, the same at every call).
DeviceOutput aim_at_device(ControlRecord& r, std::vector<HarmonicStretch>& stretches, const PlantConfig& device,
                           std::uint64_t noise_seed, const FeedbackDesignOptions& o, double fs) {
  const int playbacks = o.device_playbacks;
  DeviceOutput measure = [device, noise_seed, playbacks](const Eigen::VectorXd& v) {
    Eigen::VectorXd sum = Eigen::VectorXd::Zero(v.size());
    for (int i = 0; i < playbacks; ++i) sum += simulate(device, v, noise_seed + kPlaybackSeedStride * i).y;
    return Eigen::VectorXd(sum / playbacks);
  };
  const Eigen::VectorXd uncorrected = measure(r.u);
  std::vector<RecordPart> parts;
  r.weight = Eigen::VectorXd::Zero(r.u.size());
  if (r.noise_samples > 0) {
    parts.push_back({0, r.noise_samples});
    r.weight.head(r.noise_samples).setOnes();
  }
  const HarmonicStretch fitted{};
  stretches.clear();
  for (const SineStep& step : r.steps) {
    const auto [start, length] = steady_part(step);
    if (length <= 2 * fitted.harmonics + 1) continue;
    stretches.push_back({start, length, step.f, fitted.harmonics});
    parts.push_back({start, length});
    r.weight.segment(start, length).setOnes();
  }
  // the target on the stretches: the fundamental and mean of the device's uncorrected output
  Eigen::VectorXd steps_target = Eigen::VectorXd::Zero(r.u.size());
  add_loop_fundamentals(steps_target, uncorrected, r.steps, fs);
  for (const HarmonicStretch& h : stretches) r.y_desired.segment(h.start, h.length) = steps_target.segment(h.start, h.length);
  if (o.distortion_weighting) {
    weigh_parts_by_inverse_power(r.weight, harmonic_series(uncorrected - r.y_desired, stretches, fs), parts);
  }
  return measure;
}

}  // namespace

RecordPart steady_part(const SineStep& step) {
  return {step.start + 2 * step.fade, step.length - 3 * step.fade};
}

const char* desired_response_name(DesiredResponse d) {
  switch (d) {
    case DesiredResponse::plant_small_signal:
      return "plant-small-signal";
    case DesiredResponse::plant_fundamental:
      return "plant-fundamental";
    default:
      return "linear-model";
  }
}

DesiredResponse desired_response_from_name(const std::string& name) {
  for (DesiredResponse d :
       {DesiredResponse::linear_model, DesiredResponse::plant_small_signal, DesiredResponse::plant_fundamental}) {
    if (name == desired_response_name(d)) return d;
  }
  throw std::invalid_argument("design nn: unknown desired response '" + name +
                              "' (expected linear-model, plant-small-signal or plant-fundamental)");
}

const char* restart_choice_name(RestartChoice c) {
  return c == RestartChoice::worst_probe ? "worst-probe" : "validation-jc";
}

RestartChoice restart_choice_from_name(const std::string& name) {
  for (RestartChoice c : {RestartChoice::validation_jc, RestartChoice::worst_probe}) {
    if (name == restart_choice_name(c)) return c;
  }
  throw std::invalid_argument("design nn: unknown restart choice '" + name + "' (expected validation-jc or worst-probe)");
}

ControlRecord control_record(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass,
                             const FeedbackDesignOptions& o, std::uint64_t seed, const LoopPlant* plant) {
  require_options(o, ff.fs);
  if (o.desired != DesiredResponse::linear_model && plant == nullptr) {
    throw std::invalid_argument(std::string("design nn: the ") + desired_response_name(o.desired) +
                                " desired response needs the plant model");
  }
  if (o.distortion_weighting && plant == nullptr) {
    throw std::invalid_argument("design nn: distortion weighting needs the plant model");
  }
  if (o.distortion_weighting && o.level_weighting) {
    throw std::invalid_argument("design nn: level weighting and distortion weighting exclude each other");
  }
  const StateSpace controller = ff.controller();
  dsp::Rng rng(seed);
  ControlRecord r;
  r.program = Eigen::VectorXd::Zero(o.samples);
  const auto n_sines = static_cast<Eigen::Index>(std::round(o.sine_share * static_cast<double>(o.samples)));
  const Eigen::Index n_noise = o.samples - n_sines;
  const double noise_amplitude = max_input(ff, band_pass, 100000, seed).noise;
  for (Eigen::Index k = 0; k < n_noise; ++k) r.program[k] = rng.uniform(-noise_amplitude, noise_amplitude);
  r.noise_samples = n_noise;
  r.steps = add_stepped_sines(r.program, n_noise, controller, band_pass, o, ff.fs, rng);
  const std::vector<SineStep>& steps = r.steps;
  keep_steps_within_peak(r.program, steps, controller, band_pass, o.sine_peak);
  const Eigen::VectorXd shaped = dsp::SosFilter(band_pass).process(r.program);
  r.u = simulate(controller, shaped);
  r.y_desired = o.desired == DesiredResponse::linear_model ? simulate(ff.desired(), shaped)
                                                           : plant->small_signal_response(r.u);
  // Measured from the plant model's rest: a NARX model at rest outputs a small offset that no plant has (an
  // accelerometer has none), and its gain at DC is tiny, so a loop that tracks a target without that offset
  // learns a DC drive many times larger to null it (4.6e-4 at a DC gain of 0.0085 asked -0.054 on
  // panel-exciter's model), which the transducer would turn into coil offset and even harmonics.
  if (plant != nullptr) r.y_desired += plant->simulate(Eigen::VectorXd::Zero(r.u.size()));
  // the uncorrected loop's output (the plant model driven by u*), for the plant-fundamental target and
  // distortion weighting
  const bool needs_loop = o.desired == DesiredResponse::plant_fundamental || o.distortion_weighting;
  const Eigen::VectorXd loop = needs_loop ? plant->simulate(r.u) : Eigen::VectorXd();
  // Where each part of the record is weighed: all of the noise, and every step (with the plant-fundamental
  // target, only each step's steady part)
  std::vector<RecordPart> parts;
  if (n_noise > 0) parts.push_back({0, n_noise});
  if (o.desired == DesiredResponse::plant_fundamental) {
    r.weight = Eigen::VectorXd::Zero(o.samples);
    r.weight.head(n_noise).setOnes();
    for (const RecordPart& p : add_loop_fundamentals(r.y_desired, loop, steps, ff.fs)) {
      r.weight.segment(p.start, p.length).setOnes();
      parts.push_back(p);
    }
  } else {
    for (const SineStep& s : steps) parts.push_back({s.start, s.length});
  }
  if (o.level_weighting || o.distortion_weighting) {
    // the desired output (level weighting) or the uncorrected loop's error (distortion weighting)
    const Eigen::VectorXd weighed = o.level_weighting ? r.y_desired : Eigen::VectorXd(loop - r.y_desired);
    if (r.weight.size() == 0) r.weight = Eigen::VectorXd::Ones(o.samples);
    weigh_parts_by_inverse_power(r.weight, weighed, parts);
  }
  return r;
}

ControlRecord control_record(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass,
                             const FeedbackDesignOptions& o, std::uint64_t seed, const NarxModel* plant) {
  std::optional<LoopPlant> loop_plant;
  if (plant != nullptr) loop_plant = *plant;
  return control_record(ff, band_pass, o, seed, loop_plant ? &*loop_plant : nullptr);
}

Eigen::VectorXd harmonic_weights(const ControlRecord& record, const Eigen::VectorXd& y, double fs) {
  if (y.size() != record.y_desired.size()) {
    throw std::invalid_argument("harmonic weights: the output has " + std::to_string(y.size()) +
                                " samples, the control record " + std::to_string(record.y_desired.size()));
  }
  if (!y.allFinite()) throw std::invalid_argument("harmonic weights: the output is not finite");
  // the departure from the linear response, less each step's fundamental and mean on its steady part; on
  // it, the harmonics 2..5 below fs/2 fitted by least squares (what sensor noise adds to them shrinks with
  // the part's length)
  Eigen::VectorXd fitted = record.y_desired;
  const std::vector<RecordPart> steady = add_loop_fundamentals(fitted, y, record.steps, fs);
  Eigen::VectorXd residual = y - fitted;
  for (const SineStep& s : record.steps) {
    const auto [start, length] = steady_part(s);
    int harmonics = 0;
    while (harmonics < 4 && (harmonics + 2) * s.f < fs / 2.0) ++harmonics;
    if (length < 4 || harmonics == 0 || length <= 2 * harmonics) continue;
    Eigen::MatrixXd basis(length, 2 * harmonics);
    for (Eigen::Index k = 0; k < length; ++k) {
      const double phase = 2.0 * std::numbers::pi * s.f * static_cast<double>(start - s.start + k) / fs;
      for (int h = 0; h < harmonics; ++h) {
        basis(k, 2 * h) = std::sin((h + 2) * phase);
        basis(k, 2 * h + 1) = std::cos((h + 2) * phase);
      }
    }
    const Eigen::VectorXd part = residual.segment(start, length);
    residual.segment(start, length) = basis * basis.colPivHouseholderQr().solve(part);
  }
  // every step weighs as its steady part, the noise as itself
  std::vector<RecordPart> measured, spans;
  if (record.noise_samples > 0) {
    measured.push_back({0, record.noise_samples});
    spans.push_back(measured.back());
  }
  std::size_t next = 0;
  for (const SineStep& s : record.steps) {
    const Eigen::Index start = steady_part(s).start;
    if (next < steady.size() && steady[next].start == start) {
      measured.push_back(steady[next++]);
      spans.push_back({s.start, s.length});
    }
  }
  Eigen::VectorXd weight = Eigen::VectorXd::Ones(y.size());
  Eigen::VectorXd per_part = Eigen::VectorXd::Ones(y.size());
  weigh_parts_by_inverse_power(per_part, residual, measured);
  for (std::size_t i = 0; i < spans.size(); ++i) {
    weight.segment(spans[i].start, spans[i].length).setConstant(per_part[measured[i].start]);
  }
  return weight;
}

nlohmann::json feedback_design_options_json(const FeedbackDesignOptions& o) {
  return {{"samples", o.samples},
          {"max_iterations", o.training.max_iterations},
          {"hidden", o.structure.hidden},
          {"nu", o.structure.nu},
          {"nv", o.structure.nv},
          {"ny", o.structure.ny},
          {"sine_share", o.sine_share},
          {"sine_peak", o.sine_peak},
          {"sine_band", {o.sine_low_hz, o.sine_high_hz}},
          {"program_share", o.program_share},
          {"level_weighting", o.level_weighting},
          {"distortion_weighting", o.distortion_weighting},
          {"device_playbacks", o.device_playbacks},
          {"restarts", o.restarts},
          {"keep", restart_choice_name(o.keep)},
          {"probe_hz", o.probe_hz.empty() ? evaluation_probe_hz() : o.probe_hz},
          {"rail_penalty", o.training.rail_penalty},
          {"dc_penalty", o.training.dc_penalty},
          {"desired", desired_response_name(o.desired)},
          {"seed", o.seed}};
}

FeedbackDesign design_feedback(const LoopPlant& plant, const LqFeedforward& ff,
                               const std::vector<dsp::Biquad>& band_pass, const FeedbackDesignOptions& o,
                               const PlantConfig* device, const NeuralFeedback* start) {
  if (!dsp::same_rate(plant.fs(), ff.fs)) {
    throw std::invalid_argument("design nn: the plant model runs at " + std::to_string(plant.fs()) +
                                " Hz, the feedforward controller at " + std::to_string(ff.fs) + " Hz");
  }
  if (o.restarts < 1) throw std::invalid_argument("design nn: restarts must be >= 1, got " + std::to_string(o.restarts));
  if (start != nullptr && o.restarts != 1) {
    throw std::invalid_argument("design nn: training on from a controller is one training, not " +
                                std::to_string(o.restarts) + " restarts");
  }
  const std::vector<double> probe_hz = o.probe_hz.empty() ? evaluation_probe_hz() : o.probe_hz;
  if (o.keep == RestartChoice::worst_probe) require_probe_hz(probe_hz, ff.fs, "design nn");
  if (device != nullptr && !dsp::same_rate(device->fs, ff.fs)) {
    throw std::invalid_argument("design nn: the device runs at " + std::to_string(device->fs) +
                                " Hz, the feedforward controller at " + std::to_string(ff.fs) + " Hz");
  }
  if (o.device_playbacks < 1) {
    throw std::invalid_argument("design nn: device playbacks must be >= 1, got " + std::to_string(o.device_playbacks));
  }
  if (device != nullptr && (o.desired != DesiredResponse::plant_fundamental || o.level_weighting)) {
    throw std::invalid_argument(
        "design nn: tuning on the device asks only each sine step's harmonics of it: it needs the plant-fundamental "
        "target, and no level weighting");
  }
  ControlRecord est = control_record(ff, band_pass, o, o.seed, &plant);
  ControlRecord val = control_record(ff, band_pass, o, o.seed + 1, &plant);
  DeviceOutput measure_est, measure_val;
  std::vector<HarmonicStretch> harmonic_est, harmonic_val;
  if (device != nullptr) {
    measure_est = aim_at_device(est, harmonic_est, *device, o.seed + kDeviceNoiseSeedOffset, o, ff.fs);
    measure_val = aim_at_device(val, harmonic_val, *device, o.seed + kDeviceNoiseSeedOffset + 1, o, ff.fs);
  }
  std::optional<FeedbackDesign> best;
  double best_score = std::numeric_limits<double>::infinity();
  std::vector<double> scores;
  std::vector<std::vector<double>> probe_changes;
  for (int restart = 0; restart < o.restarts; ++restart) {
    NeuralFeedback initial = NeuralFeedback::with_structure(start ? start->structure : o.structure, plant);
    if (start != nullptr) {
      initial.net = start->net;
      initial.knee = start->knee;
    } else {
      initialize_feedback(initial, o.seed + static_cast<std::uint64_t>(restart));
    }
    FeedbackTrainingOptions training = o.training;
    training.weight_est = est.weight;
    training.weight_val = val.weight;
    training.measure_est = measure_est;
    training.measure_val = measure_val;
    training.harmonic_est = harmonic_est;
    training.harmonic_val = harmonic_val;
    if (o.training.progress) {
      training.progress = [&o, restart](FeedbackTrainingRecord r) {
        r.restart = restart;
        o.training.progress(r);
      };
    }
    FeedbackDesign d{initial, train_feedback(initial, est.u, est.y_desired, val.u, val.y_desired, training), {}, {}, restart};
    d.controller = d.training.controller;
    scores.push_back(best_validation_jc_pct(d.training));
    double score = scores.back();
    if (o.keep == RestartChoice::worst_probe) {
      probe_changes.push_back(model_thd_change_db(d.controller, ff, band_pass, probe_hz, o.sine_peak));
      score = *std::max_element(probe_changes.back().begin(), probe_changes.back().end());
    }
    if (!best || score < best_score) {
      best = std::move(d);
      best_score = score;
    }
  }
  best->restart_jc_val_pct = scores;
  best->restart_probe_change_db = probe_changes;
  return *best;
}

}  // namespace panelbass::models

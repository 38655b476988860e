#include "models/plant/plant_survey.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "dsp/excitation.h"
#include "dsp/harmonics.h"
#include "dsp/spectrum.h"
#include "models/linear/fir_estimator.h"
#include "models/linear/impulse_estimate.h"
#include "models/validation/performance.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::models {
namespace {

PlantConfig noise_free(PlantConfig plant) {
  plant.sensor.noise_rms_V = 0.0;
  return plant;
}

// Index of the largest (or smallest) |H| with frequency in [lo, hi].
Eigen::Index extreme_bin(const dsp::FrequencyResponse& frf, double lo, double hi, bool largest) {
  Eigen::Index best = -1;
  for (Eigen::Index k = 0; k < frf.frequency.size(); ++k) {
    if (frf.frequency[k] < lo || frf.frequency[k] > hi) continue;
    const double m = std::abs(frf.h[k]);
    if (best < 0 || (largest ? m > std::abs(frf.h[best]) : m < std::abs(frf.h[best]))) best = k;
  }
  return best;
}

void measure_frequency_response(const PlantConfig& plant, const PlantSurveySpec& spec, PlantSurvey& out) {
  const Eigen::VectorXd u = dsp::uniform_noise(spec.frf_samples, spec.amplitude, spec.seed + 2);
  const PlantRecord r = simulate(plant, u, spec.seed + 3);
  const dsp::FrequencyResponse frf = dsp::h1_frf(u, r.y, plant.fs, {spec.frf_segment, 0.5, dsp::Window::hann});
  const Eigen::Index main = extreme_bin(frf, 20.0, 600.0, true);
  const Eigen::Index upper = extreme_bin(frf, 600.0, 0.45 * plant.fs, true);
  out.main_resonance_hz = frf.frequency[main];
  out.upper_resonance_hz = frf.frequency[upper];
  const Eigen::Index notch = extreme_bin(frf, 600.0, out.upper_resonance_hz, false);
  out.notch_hz = frf.frequency[notch];
  std::vector<double> plateau;
  for (Eigen::Index k = 0; k < frf.frequency.size(); ++k) {
    if (frf.frequency[k] >= 400.0 && frf.frequency[k] <= 800.0) plateau.push_back(std::abs(frf.h[k]));
  }
  std::nth_element(plateau.begin(), plateau.begin() + static_cast<std::ptrdiff_t>(plateau.size() / 2), plateau.end());
  out.notch_depth_db = 20.0 * std::log10(plateau[plateau.size() / 2] / std::abs(frf.h[notch]));
}

void measure_distortion(const PlantConfig& plant, const PlantSurveySpec& spec, PlantSurvey& out) {
  dsp::SteppedSineSpec sine;
  sine.frequencies = spec.distortion_frequencies;
  sine.fs = plant.fs;
  sine.amplitude = spec.distortion_amplitude;
  const dsp::SteppedSine excitation = dsp::stepped_sine(sine);
  const PlantRecord r = simulate(noise_free(plant), excitation.signal, spec.seed);
  for (const dsp::SineStep& step : excitation.steps) {
    const Eigen::VectorXd part = r.y.segment(static_cast<Eigen::Index>(step.measure_start),
                                             static_cast<Eigen::Index>(step.measure_length));
    const dsp::HarmonicLevels h = dsp::harmonic_levels(part, plant.fs, step.frequency, 5);
    out.distortion.push_back({step.frequency, h.relative_db(2), h.relative_db(3), h.thd_percent()});
  }
}

}  // namespace

PlantSurvey survey_plant(const PlantConfig& plant, const PlantSurveySpec& spec) {
  PlantSurvey out;
  const std::size_t total = spec.estimation_samples + spec.validation_samples;
  const Eigen::VectorXd u = dsp::uniform_noise(total, spec.amplitude, spec.seed);
  const PlantRecord noisy = simulate(plant, u, spec.seed + 1);
  const PlantRecord clean = simulate(noise_free(plant), u, spec.seed + 1);
  out.j_noise_pct = j_percent(clean.y, noisy.y);

  const auto n_est = static_cast<Eigen::Index>(spec.estimation_samples);
  const ImpulseEstimate impulse =
      estimate_impulse(u.head(n_est), noisy.y.head(n_est), std::min(spec.max_lag, n_est / 2 - 1));
  out.delay_samples = impulse.delay;
  out.impulse_length_samples = impulse.length;

  // The best linear model of the record: an FIR long enough for the impulse response, fitted by least
  // squares on the estimation part, judged by simulation (J, [2A]) on both parts.
  const Eigen::VectorXd b = estimate_fir(u.head(n_est), noisy.y.head(n_est), spec.fir_taps);
  const Eigen::VectorXd y_fir = simulate_fir(b, u);
  out.j_linear_est_pct = j_percent(y_fir.head(n_est), noisy.y.head(n_est), spec.fir_taps - 1);
  out.j_linear_val_pct = j_percent(y_fir.tail(total - n_est), noisy.y.tail(total - n_est));

  measure_frequency_response(plant, spec, out);
  measure_distortion(plant, spec, out);
  return out;
}

nlohmann::json survey_to_json(const PlantSurvey& s) {
  nlohmann::json distortion = nlohmann::json::array();
  for (const DistortionPoint& d : s.distortion) {
    distortion.push_back({{"frequency_hz", d.frequency_hz}, {"h2_db", d.h2_db}, {"h3_db", d.h3_db}, {"thd_pct", d.thd_pct}});
  }
  return {{"delay_samples", s.delay_samples},
          {"impulse_length_samples", s.impulse_length_samples},
          {"main_resonance_hz", s.main_resonance_hz},
          {"upper_resonance_hz", s.upper_resonance_hz},
          {"notch_hz", s.notch_hz},
          {"notch_depth_db", s.notch_depth_db},
          {"J_linear_est_pct", s.j_linear_est_pct},
          {"J_linear_val_pct", s.j_linear_val_pct},
          {"J_noise_pct", s.j_noise_pct},
          {"distortion", distortion}};
}

}  // namespace panelbass::models

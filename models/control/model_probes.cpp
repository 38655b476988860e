#include "models/control/model_probes.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "dsp/harmonics.h"

namespace panelbass::models {

std::vector<double> evaluation_probe_hz() { return {40.0, 80.0, 160.0, 320.0}; }

void require_probe_hz(const std::vector<double>& probe_hz, double fs, const std::string& where) {
  for (double f : probe_hz) {
    if (!(f > 0.0 && 4.0 * f < fs)) {
      throw std::invalid_argument(where + ": probe " + std::to_string(f) + " Hz must be within (0, fs/4) = (0, " +
                                  std::to_string(fs / 4.0) + ")");
    }
  }
}

double probe_amplitude(const std::vector<dsp::Biquad>& band_pass, const StateSpace& controller, double f, double fs,
                       double peak) {
  const std::complex<double> gain = dsp::SosFilter(band_pass).response(f, fs) * response(controller, f, fs);
  return peak / std::max(1.0, std::abs(gain));
}

Eigen::VectorXd probe_sine(double f, double amplitude, double fs, const ProbeTiming& timing) {
  const auto n_fade = static_cast<Eigen::Index>(timing.fade_seconds * fs);
  Eigen::VectorXd sine(static_cast<Eigen::Index>(timing.settle_seconds * fs) +
                       static_cast<Eigen::Index>(timing.analysis_seconds * fs));
  for (Eigen::Index k = 0; k < sine.size(); ++k) {
    const double fade = k < n_fade ? 0.5 - 0.5 * std::cos(std::numbers::pi * static_cast<double>(k) / n_fade) : 1.0;
    sine[k] = fade * amplitude * std::sin(2.0 * std::numbers::pi * f * static_cast<double>(k) / fs);
  }
  return sine;
}

double model_probe_thd_pct(const NeuralFeedback& fb, const Eigen::VectorXd& u, bool with_feedback,
                           Eigen::Index n_analysis, double f, int harmonics) {
  const Eigen::VectorXd y = with_feedback ? simulate_closed_loop(fb, u).y : fb.plant.simulate(u);
  return dsp::harmonic_levels(y.tail(n_analysis), fb.fs, f, harmonics).thd_percent();
}

std::vector<double> model_thd_change_db(const NeuralFeedback& fb, const LqFeedforward& ff,
                                        const std::vector<dsp::Biquad>& band_pass, const std::vector<double>& probe_hz,
                                        double peak, int harmonics, const ProbeTiming& timing) {
  if (!(peak > 0.0 && peak <= 1.0)) {
    throw std::invalid_argument("model probes: the peak must be within (0, 1], got " + std::to_string(peak));
  }
  const StateSpace controller = ff.controller();
  require_probe_hz(probe_hz, fb.fs, "model probes");
  const auto n_analysis = static_cast<Eigen::Index>(timing.analysis_seconds * fb.fs);
  std::vector<double> change;
  for (double f : probe_hz) {
    const Eigen::VectorXd sine = probe_sine(f, probe_amplitude(band_pass, controller, f, fb.fs, peak), fb.fs, timing);
    const Eigen::VectorXd u = simulate(controller, dsp::SosFilter(band_pass).process(sine));
    const double without = model_probe_thd_pct(fb, u, false, n_analysis, f, harmonics);
    const double with = model_probe_thd_pct(fb, u, true, n_analysis, f, harmonics);
    change.push_back(20.0 * std::log10(with / without));
  }
  return change;
}

}  // namespace panelbass::models

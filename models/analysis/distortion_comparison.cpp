#include "models/analysis/distortion_comparison.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "dsp/excitation.h"
#include "dsp/harmonics.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::models {

std::vector<DistortionRow> measure_distortion(const SystemResponse& system, double fs, const DistortionSpec& spec) {
  if (spec.frequencies.empty()) throw std::invalid_argument("distortion: no frequencies");
  if (spec.amplitudes.empty()) throw std::invalid_argument("distortion: no amplitudes");
  if (spec.max_order < 2) {
    throw std::invalid_argument("distortion: max_order must be >= 2, got " + std::to_string(spec.max_order));
  }
  std::vector<DistortionRow> rows;
  for (const double amplitude : spec.amplitudes) {
    dsp::SteppedSineSpec sweep;
    sweep.frequencies = spec.frequencies;
    sweep.fs = fs;
    sweep.amplitude = amplitude;
    sweep.settle = spec.settle;
    sweep.measure = spec.measure;
    const dsp::SteppedSine drive = dsp::stepped_sine(sweep);
    const Eigen::VectorXd y = system(drive.signal);
    if (y.size() != drive.signal.size()) {
      throw std::invalid_argument("distortion: the system returned " + std::to_string(y.size()) + " samples for " +
                                  std::to_string(drive.signal.size()));
    }
    if (!y.allFinite()) {
      throw std::invalid_argument("distortion: the system's output is not finite at amplitude " +
                                  std::to_string(amplitude));
    }
    for (const dsp::SineStep& step : drive.steps) {
      const Eigen::VectorXd part =
          y.segment(static_cast<Eigen::Index>(step.measure_start), static_cast<Eigen::Index>(step.measure_length));
      // a_h·e^{jφ_h} = (2/N)·Σ_k y(k)·e^{−j2π·h·f·k/fs} over whole periods (dsp::harmonic_levels)
      const dsp::HarmonicLevels levels = dsp::harmonic_levels(part, fs, step.frequency, spec.max_order);
      DistortionRow row;
      row.frequency = step.frequency;
      row.amplitude = amplitude;
      row.fundamental = levels.amplitude.at(0);
      const double nan = std::numeric_limits<double>::quiet_NaN();
      row.harmonic_db.assign(static_cast<std::size_t>(spec.max_order - 1), nan);
      row.harmonic_relative.assign(static_cast<std::size_t>(spec.max_order - 1), {nan, nan});
      for (std::size_t h = 2; h <= levels.amplitude.size(); ++h) {
        row.harmonic_db[h - 2] = levels.relative_db(h);
        row.harmonic_relative[h - 2] = levels.relative(h);
      }
      row.thd_percent = levels.amplitude.size() >= 2 ? levels.thd_percent() : nan;
      rows.push_back(std::move(row));
    }
  }
  return rows;
}

std::vector<DistortionRow> plant_distortion(const PlantConfig& plant, const DistortionSpec& spec) {
  PlantConfig config = plant;
  if (spec.sensor_noise == SensorNoise::off) config.sensor.noise_rms_V = 0.0;
  return measure_distortion([&](const Eigen::VectorXd& u) { return simulate(config, u, spec.noise_seed).y; },
                            config.fs, spec);
}

std::vector<DistortionRow> model_distortion(const AnyModel& model, const DistortionSpec& spec) {
  return measure_distortion([&](const Eigen::VectorXd& u) { return model.simulate(u); }, model.fs(), spec);
}

DistortionComparison compare_distortion(const PlantConfig& plant, const AnyModel& model, const DistortionSpec& spec) {
  if (plant.fs != model.fs()) {
    throw std::invalid_argument("distortion: the plant runs at " + std::to_string(plant.fs) + " Hz, the model at " +
                                std::to_string(model.fs()) + " Hz");
  }
  return {plant_distortion(plant, spec), model_distortion(model, spec)};
}

namespace {

// 10·log10(Σ|R_h|² / Σ e_h²) with e_h = `error`(R_h, M_h), over the harmonics measured in both rows.
template <typename Error>
double cancellation_db(const DistortionRow& recorded, const DistortionRow& model, Error error) {
  if (std::abs(recorded.frequency - model.frequency) > 1e-9 * recorded.frequency) {
    throw std::invalid_argument("cancellable distortion: a row at " + std::to_string(recorded.frequency) +
                                " Hz set against one at " + std::to_string(model.frequency) + " Hz");
  }
  double total = 0.0, left = 0.0;
  std::size_t shared = 0;
  const std::size_t orders = std::min(recorded.harmonic_relative.size(), model.harmonic_relative.size());
  for (std::size_t i = 0; i < orders; ++i) {
    const std::complex<double> r = recorded.harmonic_relative[i], m = model.harmonic_relative[i];
    if (!std::isfinite(r.real()) || !std::isfinite(m.real())) continue;
    total += std::norm(r);
    const double e = error(r, m);
    left += e * e;
    ++shared;
  }
  if (shared == 0) {
    throw std::invalid_argument("cancellable distortion: no harmonic below fs/2 at " +
                                std::to_string(recorded.frequency) + " Hz");
  }
  if (left == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(total / left);
}

}  // namespace

double cancellable_db(const DistortionRow& recorded, const DistortionRow& model) {
  return cancellation_db(recorded, model, [](std::complex<double> r, std::complex<double> m) { return std::abs(r - m); });
}

double cancellable_magnitude_db(const DistortionRow& recorded, const DistortionRow& model) {
  return cancellation_db(recorded, model,
                         [](std::complex<double> r, std::complex<double> m) { return std::abs(r) - std::abs(m); });
}

}  // namespace panelbass::models

#include "models/distortion_comparison.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "dsp/excitation.h"
#include "dsp/harmonics.h"
#include "models/virtual_transducer.h"

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
      // a_h = (2/N)·|Σ_k y(k)·e^{−j2π·h·f·k/fs}| over whole periods (dsp::harmonic_levels)
      const dsp::HarmonicLevels levels = dsp::harmonic_levels(part, fs, step.frequency, spec.max_order);
      DistortionRow row;
      row.frequency = step.frequency;
      row.amplitude = amplitude;
      row.fundamental = levels.amplitude.at(0);
      row.harmonic_db.assign(static_cast<std::size_t>(spec.max_order - 1), std::numeric_limits<double>::quiet_NaN());
      for (std::size_t h = 2; h <= levels.amplitude.size(); ++h) row.harmonic_db[h - 2] = levels.relative_db(h);
      row.thd_percent = levels.amplitude.size() >= 2 ? levels.thd_percent() : std::numeric_limits<double>::quiet_NaN();
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

}  // namespace panelbass::models

#pragma once
// The virtual transducer: the plant of PlantConfig simulated sample by sample, the embedded stand-in
// for hardware. Drive (dimensionless, normally within [-1, 1]) in; sensor voltage (an accelerometer, a
// velocity or displacement sensor, or a delayed microphone), coil current, displacement and velocity out.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <vector>

#include "dsp/random.h"
#include "models/plant/converter_loop.h"
#include "models/plant/plant_config.h"

namespace panelbass::models {

/// One sample of the plant's outputs.
struct PlantSample {
  double y = 0.0;  ///< the sensor's reading, volts (filtered, delayed, noisy)
  double y_clean = 0.0;  ///< y without the sensor's noise: what the panel does, as a noise-free sensor reads it
  double i = 0.0;  ///< coil current, A
  double x = 0.0;  ///< displacement, m
  double v = 0.0;  ///< velocity, m/s
};

/// A simulated record: one column per output.
struct PlantRecord {
  Eigen::VectorXd y, i, x, v;
};

/// The lumped exciter-on-panel model of docs/transducer.md, integrated with fixed-step RK4 at
/// `oversample` steps per sample. The drive is held over each sample (DA zero-order hold), passes the
/// converter delay, the analog DA filter and the amplifier; the acceleration passes the analog AD
/// filter and is sampled at the end of the sample period (a microphone's `delay_samples` earlier, interpolated
/// between integrator steps), then the sensor's white and coloured noise are added.
/// step() is noexcept and allocation-free, so the engine can run it on the audio thread.
class VirtualTransducer {
 public:
  /// A plant at rest; `noise_seed` seeds the sensor noise.
  VirtualTransducer(PlantConfig config, std::uint64_t noise_seed);

  /// Advances one sample with `drive` held, and returns the outputs at the end of that sample.
  PlantSample step(double drive) noexcept;

  /// Back to rest, noise sequence restarted.
  void reset() noexcept;

  /// The configuration simulated.
  const PlantConfig& config() const { return config_; }

 private:
  void derivatives(const Eigen::VectorXd& s, double drive, Eigen::VectorXd& ds, double& sensed) const noexcept;
  double sensed_now(double drive) noexcept;
  double coloured_noise() noexcept;

  /// One first-order section of the coloured noise: n ← a·n + g·w, w white and unit.
  struct NoiseSection {
    double a = 0.0, g = 0.0, state = 0.0;
  };

  PlantConfig config_;
  std::uint64_t noise_seed_;
  dsp::Rng noise_;
  std::vector<ConverterSection> da_sections_, ad_sections_;  // the converters' filters (converter_loop.h)
  int mode_state_ = 4;
  int creep_state_ = -1;  // the suspension's relaxed displacement z, when the plant has creep
  int eddy_state_ = -1;   // the current in L2 of the eddy-current branch, when the plant has one
  std::vector<double> mic_line_;  // a microphone's reading at each integrator step, newest at mic_pos_
  std::size_t mic_pos_ = 0;
  std::vector<NoiseSection> noise_sections_;
  Eigen::VectorXd state_, k1_, k2_, k3_, k4_, trial_;
  std::vector<double> delay_line_;
  std::size_t delay_pos_ = 0;
};

/// Reports the fraction done, 0..1, now and then during a long computation.
using ProgressCallback = std::function<void(double)>;

/// Simulates `drive` from rest; throws std::invalid_argument if a drive sample is not finite.
PlantRecord simulate(const PlantConfig& config, const Eigen::VectorXd& drive, std::uint64_t noise_seed,
                     const ProgressCallback& progress = {});

}  // namespace panelbass::models

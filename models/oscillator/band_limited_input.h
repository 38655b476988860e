#pragma once
// The input of a continuous-time model between its samples: the sampled record reconstructed band-limited
// (dsp::resample's sinc converter onto a grid kOversampling times finer), read at any time by a cubic
// (Catmull–Rom) interpolation of that grid. A zero- or first-order hold puts the sampling's images into
// the input; the Silverbox experiment (docs/identification.md) showed the model error is set by that
// choice more than by anything else (arrow full 13.4 mV with a hold, 0.93 mV linear, 0.39 mV band-limited).

#include <Eigen/Core>

namespace panelbass::models {

/// A sampled input as a function of continuous time, in samples (t = k is sample k), band-limited between
/// the samples, held at the first sample before t = 0 and at the grid's last point (t = N − 1/kOversampling)
/// after it.
class BandLimitedInput {
 public:
  /// Grid points per sample.
  static constexpr int kOversampling = 32;

  /// Reconstructs `u` (one sample per time unit). Throws std::invalid_argument for an empty or non-finite
  /// input (dsp::resample's error).
  explicit BandLimitedInput(const Eigen::VectorXd& u);

  /// The input at time t.
  double value(double t) const;
  /// Its derivative dũ/dt at time t (per sample): the interpolant's, continuous in t.
  double slope(double t) const;
  /// The samples it was built from.
  const Eigen::VectorXd& samples() const { return samples_; }

 private:
  /// The grid's four points around t·kOversampling and the fraction of the way from the second to the third.
  void neighbours(double t, double p[4], double& fraction) const;

  Eigen::VectorXd samples_;
  Eigen::VectorXd grid_;  ///< grid_[j] = ũ(j / kOversampling)
};

}  // namespace panelbass::models

#pragma once
// A sine found in a signal: the least-squares sinusoid (with an offset) at a given frequency, and the
// frequency of a signal that is one sine, to far better than an FFT bin.

#include <Eigen/Core>
#include <optional>

namespace panelbass::dsp {

/// The least-squares fit of a·cos(2πfk/fs) + b·sin(2πfk/fs) + c to a signal.
struct SineFit {
  Eigen::Vector3d coefficients;  ///< (a, b, c)
  double residual = 0.0;         ///< the energy the fit leaves unexplained, Σ (x − fit)²
};

/// The sinusoid with an offset at frequency `f` (Hz) closest to `x` (rate fs) in least squares.
SineFit fit_sine(const Eigen::VectorXd& x, double fs, double f);

/// The frequency of the strongest sinusoid in `x`, whatever else it holds: the strongest FFT bin refined by a
/// golden-section search for the least-squares sinusoid over the neighbouring bins. Empty for fewer than 64
/// samples or a constant signal.
std::optional<double> dominant_frequency(const Eigen::VectorXd& x, double fs);

/// The frequency of `x` if it is a sine (with an offset): dominant_frequency (the maximum-likelihood
/// frequency), accepted when that sinusoid leaves less than 0.1 % of the signal's energy about its mean. Empty for
/// fewer than 64 samples, a constant signal, or anything that is not one sine.
std::optional<double> sine_frequency(const Eigen::VectorXd& x, double fs);

}  // namespace panelbass::dsp

#include "dsp/sine_fit.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <unsupported/Eigen/FFT>

namespace panelbass::dsp {

SineFit fit_sine(const Eigen::VectorXd& x, double fs, double f) {
  // Normal equations BᵀB·θ = Bᵀx with B = [cos, sin, 1], accumulated without forming B.
  Eigen::Matrix3d btb = Eigen::Matrix3d::Zero();
  Eigen::Vector3d btx = Eigen::Vector3d::Zero();
  const double w = 2.0 * std::numbers::pi * f / fs;
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    const Eigen::Vector3d b(std::cos(w * static_cast<double>(k)), std::sin(w * static_cast<double>(k)), 1.0);
    btb.noalias() += b * b.transpose();
    btx += b * x[k];
  }
  SineFit fit;
  fit.coefficients = btb.ldlt().solve(btx);
  // ‖x − Bθ‖² = xᵀx − θᵀBᵀx at the least-squares θ
  fit.residual = std::max(0.0, x.squaredNorm() - fit.coefficients.dot(btx));
  return fit;
}

std::optional<double> dominant_frequency(const Eigen::VectorXd& x, double fs) {
  const Eigen::Index n = x.size();
  if (n < 64) return std::nullopt;
  const Eigen::VectorXd centred = x.array() - x.mean();
  const double energy = centred.squaredNorm();
  // A constant signal (its mean's rounding left over, ~1e-32 of its energy, is no sinusoid).
  if (!(energy > 1e-20 * x.squaredNorm())) return std::nullopt;
  Eigen::Index size = 1;
  while (size < 2 * n) size *= 2;
  Eigen::VectorXd padded = Eigen::VectorXd::Zero(size);
  padded.head(n) = centred;
  Eigen::FFT<double> fft;
  Eigen::VectorXcd spectrum;
  fft.fwd(spectrum, padded);
  Eigen::Index peak = 1;
  for (Eigen::Index k = 1; k < size / 2; ++k) {
    if (std::abs(spectrum[k]) > std::abs(spectrum[peak])) peak = k;
  }
  const double bin = fs / static_cast<double>(size);
  double lo = std::max(bin * (static_cast<double>(peak) - 1.0), 1e-9);
  double hi = std::min(bin * (static_cast<double>(peak) + 1.0), fs / 2.0 - 1e-9);
  // Golden-section search for the frequency whose least-squares sinusoid leaves the least residual.
  const double golden = (std::sqrt(5.0) - 1.0) / 2.0;
  double a = hi - golden * (hi - lo), b = lo + golden * (hi - lo);
  double ra = fit_sine(x, fs, a).residual, rb = fit_sine(x, fs, b).residual;
  while (hi - lo > 1e-10 * fs) {
    if (ra > rb) {
      lo = a;
      a = b;
      ra = rb;
      b = lo + golden * (hi - lo);
      rb = fit_sine(x, fs, b).residual;
    } else {
      hi = b;
      b = a;
      rb = ra;
      a = hi - golden * (hi - lo);
      ra = fit_sine(x, fs, a).residual;
    }
  }
  return (lo + hi) / 2.0;
}

std::optional<double> sine_frequency(const Eigen::VectorXd& x, double fs) {
  const std::optional<double> f = dominant_frequency(x, fs);
  if (!f) return std::nullopt;
  const double energy = (x.array() - x.mean()).matrix().squaredNorm();
  if (fit_sine(x, fs, *f).residual > 1e-3 * energy) return std::nullopt;
  return f;
}

}  // namespace panelbass::dsp

#pragma once
// What the state-space model's tests train and judge on: uniform noise from std::mt19937_64, a small
// Wiener–Hammerstein system, and its small-signal linearisation (their linear start).
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <random>

#include "models/linear/linear_model.h"

namespace panelbass::testing_support {

/// n samples uniform in [−1, 1] from std::mt19937_64(seed).
inline Eigen::VectorXd mt_uniform_noise(Eigen::Index n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  Eigen::VectorXd x(n);
  for (auto& v : x) v = d(rng);
  return x;
}

/// Wiener–Hammerstein: a first-order low-pass, a saturation, another first-order filter.
inline Eigen::VectorXd wiener_hammerstein(const Eigen::VectorXd& u) {
  Eigen::VectorXd y(u.size());
  double a = 0.0, b = 0.0;
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    y(k) = b;
    a = 0.8 * a + 0.2 * u(k);
    b = 0.7 * b + 0.3 * std::tanh(2.0 * a);
  }
  return y;
}

/// wiener_hammerstein's small-signal linearisation, 0.2·2·0.3 q⁻¹ / ((1 − 0.8 q⁻¹)(1 − 0.7 q⁻¹)), at fs 1000.
inline models::LinearModel wiener_hammerstein_linearisation() {
  models::LinearModel linear;
  linear.fs = 1000.0;
  linear.tf.a = Eigen::Vector2d(-1.5, 0.56);
  linear.tf.b = Eigen::VectorXd::Constant(1, 0.12);
  linear.tf.nk = 1;
  return linear;
}

}  // namespace panelbass::testing_support

#pragma once
// Linear systems written out as the textbook difference equation, and the noise that drives them:
// independent references for the estimators' tests.

#include <Eigen/Core>
#include <cstdint>

#include "dsp/random.h"
#include "models/linear/transfer_function.h"

namespace panelbass::testing_support {

/// n samples of white Gaussian noise of standard deviation `sigma`, from dsp::Rng(seed).
inline Eigen::VectorXd gaussian(Eigen::Index n, double sigma, std::uint64_t seed) {
  dsp::Rng rng(seed);
  Eigen::VectorXd x(n);
  for (Eigen::Index i = 0; i < n; ++i) x[i] = sigma * rng.gaussian();
  return x;
}

/// The difference equation A(q)y = B(q)u + e from rest, written as plain loops (e empty: no noise).
inline Eigen::VectorXd arx_output(const models::TransferFunction& tf, const Eigen::VectorXd& u,
                                  const Eigen::VectorXd& e) {
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    double s = e.size() ? e[k] : 0.0;
    for (Eigen::Index j = 0; j < tf.b.size(); ++j) {
      if (k - tf.nk - j >= 0) s += tf.b[j] * u[k - tf.nk - j];
    }
    for (Eigen::Index i = 1; i <= tf.a.size(); ++i) {
      if (k - i >= 0) s -= tf.a[i - 1] * y[k - i];
    }
    y[k] = s;
  }
  return y;
}

/// ŷ = B/A·u from rest, as the textbook difference equation.
inline Eigen::VectorXd simulate(const models::TransferFunction& tf, const Eigen::VectorXd& u) {
  return arx_output(tf, u, Eigen::VectorXd());
}

}  // namespace panelbass::testing_support

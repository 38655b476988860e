#pragma once
// Linear systems written out as the textbook difference equation, and the noise that drives them:
// independent references for the estimators' tests.

#include <Eigen/Core>
#include <cstdint>

#include "models/linear/transfer_function.h"
#include "tests/support/noise.h"

namespace panelbass::testing_support {

/// A(q) from its poles: the monic polynomial's coefficients without its leading 1.
inline Eigen::VectorXd denominator(const Eigen::VectorXcd& poles) {
  const Eigen::VectorXd p = models::polynomial_from_roots(poles);
  return p.tail(p.size() - 1);
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

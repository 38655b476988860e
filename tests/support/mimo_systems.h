#pragma once
// Known multi-input multi-output systems for the MIMO identification tests, and their exact responses
// written out here (the recursion x(k+1) = A·x + B·u by hand), independent of the code under test.

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <vector>

#include "dsp/random.h"
#include "models/linear/mimo_state_space.h"

namespace panelbass::testing_support {

/// A p×m matrix of independent standard normal entries from dsp::Rng(seed).
inline Eigen::MatrixXd gaussian_matrix(Eigen::Index rows, Eigen::Index cols, std::uint64_t seed) {
  dsp::Rng rng(seed);
  Eigen::MatrixXd x(rows, cols);
  for (Eigen::Index j = 0; j < cols; ++j)
    for (Eigen::Index i = 0; i < rows; ++i) x(i, j) = rng.gaussian();
  return x;
}

/// A state space with pole pairs radius·e^{±jθ} for every (radius, θ) given, in a random basis (so that A is
/// full, not modal), B, C, D random; m inputs, p outputs.
inline models::MimoStateSpace mimo_system(const std::vector<std::pair<double, double>>& poles, Eigen::Index m,
                                          Eigen::Index p, std::uint64_t seed) {
  const auto n = static_cast<Eigen::Index>(2 * poles.size());
  Eigen::MatrixXd modal = Eigen::MatrixXd::Zero(n, n);
  for (std::size_t j = 0; j < poles.size(); ++j) {
    const auto s = static_cast<Eigen::Index>(2 * j);
    const double re = poles[j].first * std::cos(poles[j].second), im = poles[j].first * std::sin(poles[j].second);
    modal(s, s) = modal(s + 1, s + 1) = re;
    modal(s, s + 1) = im;
    modal(s + 1, s) = -im;
  }
  const Eigen::MatrixXd T = Eigen::MatrixXd::Identity(n, n) + 0.3 * gaussian_matrix(n, n, seed);
  models::MimoStateSpace ss;
  ss.A = T * modal * T.inverse();
  ss.B = gaussian_matrix(n, m, seed + 1);
  ss.C = gaussian_matrix(p, n, seed + 2);
  ss.D = 0.1 * gaussian_matrix(p, m, seed + 3);
  return ss;
}

/// The output (N×p) of `ss` in periodic steady state for one period `u` (N×m): the recursion run from rest
/// over `settle` periods first (their outputs dropped).
inline Eigen::MatrixXd steady_state_output(const models::MimoStateSpace& ss, const Eigen::MatrixXd& u, int settle) {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(ss.A.rows());
  Eigen::MatrixXd y(u.rows(), ss.C.rows());
  for (int q = 0; q <= settle; ++q) {
    for (Eigen::Index k = 0; k < u.rows(); ++k) {
      const Eigen::VectorXd uk = u.row(k).transpose();
      if (q == settle) y.row(k) = (ss.C * x + ss.D * uk).transpose();
      x = (ss.A * x + ss.B * uk).eval();
    }
  }
  return y;
}

/// The Markov parameters D, C·B, C·A·B, … (count of them), by repeated multiplication.
inline std::vector<Eigen::MatrixXd> true_markov(const models::MimoStateSpace& ss, Eigen::Index count) {
  std::vector<Eigen::MatrixXd> h{ss.D};
  Eigen::MatrixXd power = Eigen::MatrixXd::Identity(ss.A.rows(), ss.A.rows());
  for (Eigen::Index k = 1; k < count; ++k) {
    h.push_back(ss.C * power * ss.B);
    power = power * ss.A;
  }
  return h;
}

}  // namespace panelbass::testing_support

#include "models/linear/fir_estimator.h"

#include <Eigen/Cholesky>
#include <stdexcept>
#include <string>

namespace panelbass::models {

Eigen::VectorXd estimate_fir(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index taps, double ridge) {
  const Eigen::Index n = taps, N = u.size();
  if (y.size() != N) throw std::invalid_argument("FIR: input and output lengths differ");
  if (n < 1) throw std::invalid_argument("FIR: taps must be >= 1");
  if (N < 2 * n) {
    throw std::invalid_argument("FIR: " + std::to_string(N) + " samples are too few for " + std::to_string(n) +
                                " taps (need at least " + std::to_string(2 * n) + ")");
  }
  // Normal equations R·b = r with R_ij = Σ_{k=n−1}^{N−1} u(k−i)·u(k−j), r_i = Σ u(k−i)·y(k).
  // The first row costs O(N·n); every other entry follows from its upper-left neighbour:
  // R_{i+1,j+1} = R_ij + u(n−2−i)·u(n−2−j) − u(N−1−i)·u(N−1−j).
  Eigen::MatrixXd R(n, n);
  Eigen::VectorXd r(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    R(0, j) = u.segment(n - 1, N - n + 1).dot(u.segment(n - 1 - j, N - n + 1));
    r(j) = y.segment(n - 1, N - n + 1).dot(u.segment(n - 1 - j, N - n + 1));
  }
  for (Eigen::Index i = 0; i + 1 < n; ++i) {
    for (Eigen::Index j = i; j + 1 < n; ++j) {
      R(i + 1, j + 1) = R(i, j) + u(n - 2 - i) * u(n - 2 - j) - u(N - 1 - i) * u(N - 1 - j);
    }
  }
  R.triangularView<Eigen::StrictlyLower>() = R.transpose();
  if (!(R(0, 0) > 0.0)) throw std::invalid_argument("FIR: the input has no energy");
  if (ridge > 0.0) R.diagonal().array() += ridge * R.diagonal().mean();
  Eigen::LDLT<Eigen::MatrixXd> ldlt(R);
  // LDLT reports exactly zero pivots as "positive"; a pivot this small relative to the largest means
  // the input's autocorrelation matrix is singular (e.g. a constant input for more than one tap).
  const Eigen::VectorXd pivots = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || !(pivots.minCoeff() > 1e-12 * pivots.maxCoeff())) {
    throw std::invalid_argument("FIR: the input does not excite " + std::to_string(n) + " taps (singular)");
  }
  Eigen::VectorXd b = ldlt.solve(r);
  if (!b.allFinite()) throw std::invalid_argument("FIR: the input does not excite " + std::to_string(n) + " taps");
  return b;
}

Eigen::VectorXd simulate_fir(const Eigen::VectorXd& b, const Eigen::VectorXd& u) {
  const Eigen::Index N = u.size(), n = b.size();
  Eigen::VectorXd y = Eigen::VectorXd::Zero(N);
  for (Eigen::Index k = 0; k < N; ++k) {
    const Eigen::Index m = std::min(n, k + 1);
    // y(k) = Σ_j b_j·u(k−j)
    y(k) = b.head(m).dot(u.segment(k - m + 1, m).reverse());
  }
  return y;
}

}  // namespace panelbass::models

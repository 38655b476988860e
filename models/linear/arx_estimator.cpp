#include "models/linear/arx_estimator.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "models/linear/estimation_error.h"
#include "models/linear/estimator_checks.h"
#include "models/optimization/least_squares.h"

namespace panelbass::models {
TransferFunction estimate_arx(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const ModelOrders& orders) {
  const std::string name = orders_name("ARX", orders);
  require_valid_orders(orders, name);
  require_usable_record(u, y, name);
  const Eigen::Index N = u.size();

  const Eigen::Index na = orders.na, nb = orders.nb, nk = orders.nk, P = na + nb;
  const Eigen::Index first = std::max<Eigen::Index>(na, nk + nb - 1);
  const Eigen::Index rows = std::max<Eigen::Index>(N - first, 0);
  if (rows < P) {
    throw EstimationError(name + ": " + std::to_string(rows) + " usable samples are too few for " +
                          std::to_string(P) + " parameters");
  }

  // φ(k) = [−y(k−1) … −y(k−na), u(k−nk) … u(k−nk−nb+1)], k = first … N−1, with the target y(k) as the
  // last column; every column is a contiguous slice of u or y, so the matrix is built by block copies.
  Eigen::MatrixXd phi(rows, P + 1);
  for (Eigen::Index i = 1; i <= na; ++i) phi.col(i - 1) = -y.segment(first - i, rows);
  for (Eigen::Index j = 0; j < nb; ++j) phi.col(na + j) = u.segment(first - nk - j, rows);
  phi.col(P) = y.segment(first, rows);

  // Columns scaled to unit norm so that the rank threshold is relative to each regressor's own size
  // (a record whose y is 1e-6 of u is not rank deficient).
  Eigen::VectorXd scale(P);
  for (Eigen::Index c = 0; c < P; ++c) {
    const double norm = phi.col(c).norm();
    if (!(norm > 0.0)) {
      const std::string regressor = c < na ? "-y(k-" + std::to_string(c + 1) + ")"
                                           : "u(k-" + std::to_string(nk + c - na) + ")";
      throw EstimationError(name + ": the data do not excite " + std::to_string(P) + " parameters (the regressor " +
                            regressor + " is zero on every usable sample)");
    }
    scale[c] = 1.0 / norm;
    phi.col(c) *= scale[c];
  }

  // min ‖Φθ − y‖ (optimization/least_squares.h: never the normal equations), the rank from the unit-norm columns.
  const LeastSquares fit = least_squares(phi.leftCols(P), phi.col(P), 1e-10);
  if (fit.rank < P) {
    throw EstimationError(name + ": the input does not excite " + std::to_string(P) + " parameters (rank " +
                          std::to_string(fit.rank) + ")");
  }
  const Eigen::VectorXd theta = fit.theta.cwiseProduct(scale);
  if (!theta.allFinite()) {
    throw EstimationError(name + ": the input does not excite " + std::to_string(P) + " parameters");
  }

  TransferFunction tf;
  tf.a = theta.head(na);
  tf.b = theta.tail(nb);
  tf.nk = orders.nk;
  return tf;
}

}  // namespace panelbass::models

#include "models/optimization/least_squares.h"

#include <Eigen/QR>
#include <algorithm>
#include <stdexcept>
#include <string>

namespace panelbass::models {
namespace {

// Rows of Φ reduced at a time: a block of a few tens of columns then fits in the cache.
constexpr Eigen::Index kRowsPerBlock = 1024;

}  // namespace

LeastSquares least_squares(const Eigen::Ref<const Eigen::MatrixXd>& phi, const Eigen::Ref<const Eigen::VectorXd>& y,
                           double threshold) {
  if (phi.rows() != y.size()) {
    throw std::invalid_argument("least_squares: " + std::to_string(phi.rows()) + " rows of regressors against " +
                                std::to_string(y.size()) + " samples");
  }
  const Eigen::Index p = phi.cols();
  LeastSquares out;
  if (p == 0) return out;
  // [Φ y]'s triangular factor, a block of rows at a time (each block with the factor so far on top): the same
  // orthogonal reduction as one QR of the whole, but each sweep stays in the cache.
  const Eigen::Index cols = p + 1;
  const Eigen::Index block = std::max<Eigen::Index>(kRowsPerBlock, 2 * cols);
  Eigen::MatrixXd stacked(cols + block, cols);
  Eigen::Index have = 0;  // rows of the factor so far at the top of `stacked` (≤ cols)
  for (Eigen::Index at = 0; at < phi.rows(); at += block) {
    const Eigen::Index m = std::min(block, phi.rows() - at);
    stacked.middleRows(have, m) << phi.middleRows(at, m), y.segment(at, m);
    Eigen::Ref<Eigen::MatrixXd> rows = stacked.topRows(have + m);
    const Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> in_place(rows);  // R overwrites the rows' upper part
    have = std::min(have + m, cols);
    stacked.topRows(have).triangularView<Eigen::StrictlyLower>().setZero();
  }
  const Eigen::Index k = std::min(have, p);  // fewer rows than columns: R₁₁ is k×p
  const Eigen::MatrixXd r = stacked.topLeftCorner(k, p);
  const Eigen::VectorXd rhs = stacked.col(p).head(k);
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> small(r);
  if (threshold >= 0.0) small.setThreshold(threshold);
  // The basic solution at the revealed rank: the parameters beyond it are zero (Eigen's solve() would divide by
  // every pivot above a far smaller threshold, and give a near-duplicate pair of columns huge opposite values).
  out.rank = small.rank();
  const Eigen::VectorXd z = small.householderQ().transpose() * rhs;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(p);
  x.head(out.rank) = small.matrixR().topLeftCorner(out.rank, out.rank).triangularView<Eigen::Upper>().solve(z.head(out.rank));
  out.theta = small.colsPermutation() * x;
  return out;
}

}  // namespace panelbass::models

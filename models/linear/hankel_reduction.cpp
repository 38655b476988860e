#include "models/linear/hankel_reduction.h"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <stdexcept>
#include <string>

namespace panelbass::models {

StateSpace hankel_reduction(const Eigen::VectorXd& impulse, int order, Eigen::VectorXd* singular_values) {
  if (order < 1) throw std::invalid_argument("Hankel reduction: order must be >= 1, got " + std::to_string(order));
  if (!impulse.allFinite()) throw std::invalid_argument("Hankel reduction: the impulse response is not finite");
  // Markov parameters h_1..h_m follow impulse[0] = D. The shift-invariance step needs one block row more
  // than the order: rows ≥ order + 1 and columns ≥ order, i.e. m ≥ 2·order + 1.
  const Eigen::Index m = impulse.size() - 1;
  const Eigen::Index need = 2 * static_cast<Eigen::Index>(order) + 1;
  if (m < need) {
    throw std::invalid_argument("Hankel reduction: " + std::to_string(std::max<Eigen::Index>(m, 0)) +
                                " Markov parameters are too few for order " + std::to_string(order) +
                                " (need at least " + std::to_string(need) + ")");
  }
  const Eigen::Index rows = (m + 1) / 2;   // ⌈m/2⌉
  const Eigen::Index cols = m - rows + 1;  // rows + cols − 1 = m: every Markov parameter is used
  const Eigen::Index n = order;

  // H(i, j) = h_{1+i+j} = C·A^(i+j)·B = (O·Γ)(i, j), O the observability and Γ the controllability matrix.
  Eigen::MatrixXd H(rows, cols);
  for (Eigen::Index j = 0; j < cols; ++j) H.col(j) = impulse.segment(1 + j, rows);

  const Eigen::BDCSVD<Eigen::MatrixXd> svd(H, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& sigma = svd.singularValues();
  if (singular_values != nullptr) *singular_values = sigma;

  // H ≈ U_n·Σ_n·V_nᵀ = (U_n·Σ_n^½)·(Σ_n^½·V_nᵀ) = O·Γ, truncated to the n largest singular values.
  const Eigen::VectorXd root = sigma.head(n).cwiseSqrt();
  const Eigen::MatrixXd O = svd.matrixU().leftCols(n) * root.asDiagonal();
  const Eigen::MatrixXd Gamma = root.asDiagonal() * svd.matrixV().leftCols(n).transpose();

  // Shift invariance: O(1:rows, :) = O(0:rows−1, :)·A, solved by least squares (minimum norm, so states
  // whose singular value is zero get A-rows of zeros: poles at the origin that nothing excites).
  StateSpace ss;
  ss.A = O.topRows(rows - 1).completeOrthogonalDecomposition().solve(O.bottomRows(rows - 1));
  ss.B = Gamma.col(0);
  ss.C = O.row(0);
  ss.D = impulse[0];
  return ss;
}

}  // namespace panelbass::models

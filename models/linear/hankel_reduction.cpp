#include "models/linear/hankel_reduction.h"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <stdexcept>
#include <string>

namespace panelbass::models {

MimoStateSpace kung_realization(const std::vector<Eigen::MatrixXd>& markov, int order, Eigen::VectorXd* singular_values) {
  if (order < 1) throw std::invalid_argument("Hankel reduction: order must be >= 1, got " + std::to_string(order));
  if (markov.empty()) throw std::invalid_argument("Hankel reduction: no Markov parameters");
  const Eigen::Index p = markov.front().rows(), q = markov.front().cols();
  for (std::size_t k = 0; k < markov.size(); ++k) {
    if (markov[k].rows() != p || markov[k].cols() != q) {
      throw std::invalid_argument("Hankel reduction: Markov parameter " + std::to_string(k) + " is " +
                                  std::to_string(markov[k].rows()) + "×" + std::to_string(markov[k].cols()) + ", the first " +
                                  std::to_string(p) + "×" + std::to_string(q));
    }
    if (!markov[k].allFinite()) throw std::invalid_argument("Hankel reduction: the impulse response is not finite");
  }
  // Markov parameters h_1..h_M follow markov[0] = D. The shift-invariance step needs one block row more
  // than the order: rows ≥ order + 1 and columns ≥ order, i.e. M ≥ 2·order + 1 (enough for any p, m ≥ 1).
  const auto M = static_cast<Eigen::Index>(markov.size()) - 1;
  const Eigen::Index need = 2 * static_cast<Eigen::Index>(order) + 1;
  if (M < need) {
    throw std::invalid_argument("Hankel reduction: " + std::to_string(std::max<Eigen::Index>(M, 0)) +
                                " Markov parameters are too few for order " + std::to_string(order) +
                                " (need at least " + std::to_string(need) + ")");
  }
  const Eigen::Index rows = (M + 1) / 2;   // ⌈M/2⌉ block rows
  const Eigen::Index cols = M - rows + 1;  // rows + cols − 1 = M: every Markov parameter is used
  const Eigen::Index n = order;

  // H(i, j) = h_{1+i+j} = C·A^(i+j)·B = (O·Γ)(i, j), O the observability and Γ the controllability
  // matrix, each block p×m.
  Eigen::MatrixXd H(rows * p, cols * q);
  for (Eigen::Index i = 0; i < rows; ++i) {
    for (Eigen::Index j = 0; j < cols; ++j) H.block(i * p, j * q, p, q) = markov[static_cast<std::size_t>(1 + i + j)];
  }

  const Eigen::BDCSVD<Eigen::MatrixXd> svd(H, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& sigma = svd.singularValues();
  if (singular_values != nullptr) *singular_values = sigma;
  if (n > sigma.size()) {
    throw std::invalid_argument("Hankel reduction: order " + std::to_string(order) + " exceeds the Hankel matrix's rank bound " +
                                std::to_string(sigma.size()));
  }

  // H ≈ U_n·Σ_n·V_nᵀ = (U_n·Σ_n^½)·(Σ_n^½·V_nᵀ) = O·Γ, truncated to the n largest singular values.
  const Eigen::VectorXd root = sigma.head(n).cwiseSqrt();
  const Eigen::MatrixXd O = svd.matrixU().leftCols(n) * root.asDiagonal();
  const Eigen::MatrixXd Gamma = root.asDiagonal() * svd.matrixV().leftCols(n).transpose();

  // Shift invariance: O(p:, :) = O(:−p, :)·A, solved by least squares (minimum norm, so states whose
  // singular value is zero get A-rows of zeros: poles at the origin that nothing excites).
  MimoStateSpace ss;
  ss.A = O.topRows((rows - 1) * p).completeOrthogonalDecomposition().solve(O.bottomRows((rows - 1) * p));
  ss.B = Gamma.leftCols(q);
  ss.C = O.topRows(p);
  ss.D = markov.front();
  return ss;
}

StateSpace hankel_reduction(const Eigen::VectorXd& impulse, int order, Eigen::VectorXd* singular_values) {
  if (!impulse.allFinite()) throw std::invalid_argument("Hankel reduction: the impulse response is not finite");
  std::vector<Eigen::MatrixXd> markov;
  markov.reserve(static_cast<std::size_t>(impulse.size()));
  for (Eigen::Index k = 0; k < impulse.size(); ++k) markov.push_back(Eigen::MatrixXd::Constant(1, 1, impulse[k]));
  if (markov.empty()) markov.push_back(Eigen::MatrixXd::Zero(1, 1));
  const MimoStateSpace mimo = kung_realization(markov, order, singular_values);
  StateSpace ss;
  ss.A = mimo.A;
  ss.B = mimo.B.col(0);
  ss.C = mimo.C.row(0);
  ss.D = mimo.D(0, 0);
  return ss;
}

}  // namespace panelbass::models

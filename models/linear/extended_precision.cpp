#include "models/linear/extended_precision.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace panelbass::models::extended {
MatrixL solve_discrete_lyapunov(const MatrixL& A, const MatrixL& Q) {
  const Eigen::Index n = A.rows();
  const Eigen::ComplexSchur<MatrixL> schur(A);
  const MatrixCL& T = schur.matrixT();
  const MatrixCL& U = schur.matrixU();
  const MatrixCL Qt = U.adjoint() * Q.cast<ComplexL>() * U;
  MatrixCL X = MatrixCL::Zero(n, n);
  VectorCL known(n);
  MatrixCL M(n, n);
  // Column j of X = T·X·Tᴴ + Q̃, with T upper triangular, from the last column back:
  //   (I − conj(T_jj)·T)·X(:,j) = Q̃(:,j) + T·Σ_{l>j} conj(T_jl)·X(:,l)
  for (Eigen::Index j = n - 1; j >= 0; --j) {
    known.setZero();
    for (Eigen::Index l = j + 1; l < n; ++l) known += std::conj(T(j, l)) * X.col(l);
    const VectorCL rhs = Qt.col(j) + T.triangularView<Eigen::Upper>() * known;
    M = -std::conj(T(j, j)) * T;
    M.diagonal().array() += ComplexL(1.0L);
    X.col(j) = M.triangularView<Eigen::Upper>().solve(rhs);
  }
  const MatrixL W = (U * X * U.adjoint()).real();
  return (W + W.transpose()) / 2.0L;  // symmetric by construction; remove rounding asymmetry
}


Real spectral_radius(const MatrixL& A) {
  if (A.rows() == 0) return 0.0L;
  const Eigen::ComplexSchur<MatrixL> schur(A, false);
  Real r = 0.0L;
  for (Eigen::Index i = 0; i < A.rows(); ++i) r = std::max(r, std::abs(schur.matrixT()(i, i)));
  return r;
}

}  // namespace panelbass::models::extended

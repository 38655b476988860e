#pragma once
// Linear algebra in long double for the badly conditioned problems of linear models: a high-order
// polynomial's companion form, Riccati and Lyapunov equations with poles near the unit circle. The 11
// extra mantissa bits (x86 extended precision) keep the double-precision results accurate.

#include <Eigen/Core>
#include <complex>

namespace panelbass::models::extended {

using Real = long double;                                                         ///< the working precision
using ComplexL = std::complex<Real>;                                              ///< a complex in it
using MatrixL = Eigen::Matrix<Real, Eigen::Dynamic, Eigen::Dynamic>;              ///< a real matrix
using VectorL = Eigen::Matrix<Real, Eigen::Dynamic, 1>;                           ///< a real column
using RowVectorL = Eigen::Matrix<Real, 1, Eigen::Dynamic>;                        ///< a real row
using MatrixCL = Eigen::Matrix<ComplexL, Eigen::Dynamic, Eigen::Dynamic>;         ///< a complex matrix
using VectorCL = Eigen::Matrix<ComplexL, Eigen::Dynamic, 1>;                      ///< a complex column

/// The solution X of the discrete Lyapunov equation X = A·X·Aᵀ + Q for a stable A, by Bartels–Stewart
/// on the complex Schur form A = U·T·Uᴴ (backward stable even for the very non-normal companion
/// matrices that doubling iterations lose accuracy on); symmetrised.
MatrixL solve_discrete_lyapunov(const MatrixL& A, const MatrixL& Q);

/// Largest eigenvalue modulus of A (the spectral radius), from the complex Schur form; 0 for an empty A.
Real spectral_radius(const MatrixL& A);

}  // namespace panelbass::models::extended

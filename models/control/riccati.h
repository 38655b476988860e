#pragma once
// The discrete algebraic Riccati equation of the LQ design ([7A]) and its optimal gain: structured
// doubling refined by Newton's method, in long double, with the residual checked.

#include <Eigen/Core>

namespace panelbass::models {

/// The stabilising solution P of the discrete algebraic Riccati equation
///   P = AᵀPA − AᵀPB·(R + BᵀPB)⁻¹·BᵀPA + Q
/// (Q symmetric ≥ 0, R > 0), by structured doubling refined by Newton's method (started from L = 0 when
/// doubling fails on a stiff problem and A is stable), computed in long double; the relative residual is
/// checked. Throws std::invalid_argument for mismatched sizes, non-finite entries or a pair (A, B) that
/// has no stabilising solution (naming which: an unreachable mode outside the unit circle, or a mode on
/// it that Q does not see).
Eigen::MatrixXd solve_dare(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, const Eigen::MatrixXd& Q, double R);

/// The optimal state feedback of [7A]: L = (R + BᵀPB)⁻¹·BᵀPA for the P of solve_dare().
Eigen::RowVectorXd lq_gain(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, const Eigen::MatrixXd& P, double R);

}  // namespace panelbass::models

#pragma once
// Linear least squares for tall regressor matrices (tens of thousands of rows, tens of columns): the
// estimators and the diagnosis's term fits solve min ‖Φθ − y‖ this way, never by the normal equations.

#include <Eigen/Core>

namespace panelbass::models {

/// The solution θ of min ‖Φθ − y‖ and the numerical rank of Φ.
struct LeastSquares {
  Eigen::VectorXd theta;  ///< the basic solution: a parameter beyond the rank is zero
  Eigen::Index rank = 0;  ///< the rank revealed with the threshold given
};

/// min ‖Φθ − y‖: a Householder QR of [Φ y], a block of rows at a time, reduces the N×(P+1) problem to its
/// triangular factor R = [R₁₁ r; 0 ρ] (R₁₁ P×P, with the singular values of Φ) and min ‖R₁₁θ − r‖, which a
/// column-pivoting QR of the small R₁₁ solves at the rank it reveals. The same answer as a column-pivoting QR of Φ
/// itself, without its pivoting sweeps over all N rows. `threshold` is that QR's (a pivot below threshold × the
/// largest counts as zero); a negative one keeps Eigen's default.
LeastSquares least_squares(const Eigen::Ref<const Eigen::MatrixXd>& phi, const Eigen::Ref<const Eigen::VectorXd>& y,
                           double threshold = -1.0);

}  // namespace panelbass::models

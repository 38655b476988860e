#pragma once
// FIR models by least squares: the analytic output-error optimum for a finite impulse response.

#include <Eigen/Core>

namespace panelbass::models {

/// Coefficients b_0..b_{n-1} minimising Σ_k (y(k) − Σ_j b_j·u(k−j))² over k = n−1..N−1 (no samples
/// before the record are assumed). Costs O(N·n + n³), never forms the N×n regressor matrix.
/// With `ridge` > 0, ridge·(mean of Σu²) is added to the normal equations' diagonal: directions the
/// input does not excite (a band-limited or periodic input) get no response instead of a singular system.
/// Throws std::invalid_argument when the record is shorter than 2n samples, the input has no energy, or
/// (ridge 0) the input does not excite n taps.
Eigen::VectorXd estimate_fir(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index taps, double ridge = 0.0);

/// Output of the FIR `b` driven by `u` from rest (zero input before the record).
Eigen::VectorXd simulate_fir(const Eigen::VectorXd& b, const Eigen::VectorXd& u);

}  // namespace panelbass::models

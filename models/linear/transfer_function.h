#pragma once
// Discrete-time SISO transfer functions: the polynomial form of every linear model.

#include <Eigen/Core>
#include <complex>

namespace panelbass::models {

/// y(k) = B(q)/A(q)·u(k) with A(q) = 1 + a_1 q⁻¹ + … + a_na q⁻ⁿᵃ and
/// B(q) = q⁻ⁿᵏ·(b_0 + b_1 q⁻¹ + … + b_{nb−1} q⁻⁽ⁿᵇ⁻¹⁾). An FIR model has na = 0.
struct TransferFunction {
  Eigen::VectorXd a;   ///< a_1..a_na (the leading 1 is implicit)
  Eigen::VectorXd b;   ///< b_0..b_{nb−1}
  int nk = 0;          ///< input delay in samples

  /// Number of poles (na).
  int na() const { return static_cast<int>(a.size()); }
  /// Number of numerator coefficients (nb).
  int nb() const { return static_cast<int>(b.size()); }
  /// The poles: roots of z^na·A(z) (empty for an FIR).
  Eigen::VectorXcd poles() const;
  /// The finite zeros: roots of z^(nb−1)·(b_0 + b_1 z⁻¹ + …), leading zero coefficients dropped.
  Eigen::VectorXcd zeros() const;
  /// True when every pole lies strictly inside the circle of radius 1 − margin.
  bool is_stable(double margin = 0.0) const;
  /// H(e^{jω}) at `frequency` Hz for sample rate `fs`.
  std::complex<double> response(double frequency, double fs) const;
  /// True when every coefficient is finite.
  bool all_finite() const { return a.allFinite() && b.allFinite(); }
};

/// Monic polynomial coefficients [1, c_1, …, c_n] of Π (z − r_k) (conjugate pairs give real results;
/// the imaginary parts left by rounding are dropped).
Eigen::VectorXd polynomial_from_roots(const Eigen::VectorXcd& roots);

/// Roots of c_0 z^n + c_1 z^(n−1) + … + c_n (c_0 ≠ 0), as eigenvalues of the companion matrix.
Eigen::VectorXcd polynomial_roots(const Eigen::VectorXd& coefficients);

/// A discrete-time pole read as the continuous-time mode s = ln(p)·fs it samples.
struct PoleMode {
  double natural_hz = 0.0;     ///< |s|/2π: the undamped natural frequency (a real pole's corner)
  double damped_hz = 0.0;      ///< |Im s|/2π: the frequency it rings at (0 for a real pole)
  double damping_ratio = 1.0;  ///< −Re s/|s| (1 for a pole at z = 1)
};

/// The continuous-time mode of the nonzero pole `pole` at sample rate `fs`.
PoleMode pole_mode(std::complex<double> pole, double fs);

}  // namespace panelbass::models

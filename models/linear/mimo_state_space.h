#pragma once
// Multi-input multi-output linear state-space models: x(k+1) = A·x + B·u, y = C·x + D·u with u ∈ ℝ^m,
// y ∈ ℝ^p (the single-input single-output `StateSpace` is the 1×1 case, kept separate because every SISO
// caller works with scalars).

#include <Eigen/Core>
#include <complex>
#include <vector>

namespace panelbass::models {

/// x(k+1) = A·x(k) + B·u(k),  y(k) = C·x(k) + D·u(k);  A n×n, B n×m, C p×n, D p×m.
struct MimoStateSpace {
  Eigen::MatrixXd A, B, C, D;

  /// Number of states n.
  Eigen::Index order() const { return A.rows(); }
  /// Number of inputs m.
  Eigen::Index inputs() const { return D.cols(); }
  /// Number of outputs p.
  Eigen::Index outputs() const { return D.rows(); }
};

/// Throws std::invalid_argument, prefixed with `where`, unless the four matrices agree in shape and are finite.
void check_shape(const MimoStateSpace& ss, const char* where);

/// The spectral radius of A: the largest pole magnitude (0 for a static model).
double spectral_radius(const MimoStateSpace& ss);

/// The Markov parameters D, C·B, C·A·B, …: `count` p×m matrices, h[0] = D, h[k] = C·A^(k−1)·B.
std::vector<Eigen::MatrixXd> markov_parameters(const MimoStateSpace& ss, Eigen::Index count);

/// Outputs (N×p) of `ss` driven by `u` (N×m, one sample a row) from state `x0` (zero when empty).
Eigen::MatrixXd simulate(const MimoStateSpace& ss, const Eigen::MatrixXd& u, const Eigen::VectorXd& x0 = {});

/// Outputs (N×p) for a record `u` (N×m) that continues a periodic steady state: the last `warmup` rows of
/// `u` are played first, from rest, and their outputs dropped (the FSM benchmark's protocol, whose
/// baseline notebook prepends 1000 samples); `warmup` may exceed N (the record is then repeated).
Eigen::MatrixXd simulate_after_warmup(const MimoStateSpace& ss, const Eigen::MatrixXd& u, Eigen::Index warmup);

/// The p×m frequency response C·(zI − A)⁻¹·B + D at z = e^{j2πf/fs}.
Eigen::MatrixXcd response(const MimoStateSpace& ss, double frequency, double fs);

}  // namespace panelbass::models

#pragma once
// State-space forms of linear models: how they are simulated (never as one high-order direct-form
// polynomial), balanced, and started from measured data.

#include <Eigen/Core>

#include "models/linear/transfer_function.h"

namespace panelbass::models {

/// x(k+1) = A·x(k) + B·u(k),  y(k) = C·x(k) + D·u(k).
struct StateSpace {
  Eigen::MatrixXd A;
  Eigen::VectorXd B;
  Eigen::RowVectorXd C;
  double D = 0.0;

  /// Number of states.
  int order() const { return static_cast<int>(A.rows()); }
};

/// A minimal realisation of `tf` (max(na, nk + nb − 1) states: the input delay needs states only beyond
/// the na the poles already bring), balanced when the model is stable (controllability and
/// observability Gramians equal and diagonal), which keeps high orders well conditioned. A polynomial
/// too ill conditioned to balance faithfully (response off by more than 1e-8 of its peak) keeps the
/// observable canonical form. Throws std::invalid_argument for non-finite coefficients.
StateSpace realize(const TransferFunction& tf);

/// The balanced realisation of a stable `ss` and its Hankel singular values (descending).
/// Throws std::invalid_argument if `ss` is not stable or not minimal.
StateSpace balance(const StateSpace& ss, Eigen::VectorXd* hankel_singular_values = nullptr);

/// The transfer function of `ss` (nk = 0; leading zero numerator coefficients kept as b).
TransferFunction to_transfer_function(const StateSpace& ss);

/// Throws std::invalid_argument, prefixed with `where`, unless A is n×n and B, C have length n.
void check_shape(const StateSpace& ss, const char* where);

/// Output of `ss` driven by `u` from state `x0` (zero when empty).
Eigen::VectorXd simulate(const StateSpace& ss, const Eigen::VectorXd& u, const Eigen::VectorXd& x0 = {});

/// The initial state that best explains the first `samples` measured outputs `y` given `u`, by least
/// squares on y(k) − (forced response)(k) = C·A^k·x0 (the benchmark protocol's initialisation).
Eigen::VectorXd initial_state(const StateSpace& ss, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                              Eigen::Index samples);

/// H(e^{jω}) of `ss` at `frequency` Hz for sample rate `fs`.
std::complex<double> response(const StateSpace& ss, double frequency, double fs);

}  // namespace panelbass::models

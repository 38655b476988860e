#pragma once
// Output-error models by Levenberg–Marquardt on the simulation error with exact gradients.

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "models/linear/transfer_function.h"

namespace panelbass::models {

/// How an output-error fit runs.
struct OeOptions {
  int max_iterations = 100;
  double tolerance = 1e-7;          ///< stop when the loss improves by less than this, relatively
  double stability_margin = 1e-6;   ///< every pole kept inside radius 1 − margin
  Eigen::Index transient_skip = 0;  ///< samples at the start left out of the loss ([5M])
  std::function<void(int iteration, double loss)> progress;  ///< called after each iteration
};

/// The result of an output-error fit.
struct OeResult {
  TransferFunction tf;
  int iterations = 0;
  double loss = 0.0;                  ///< V = mean squared simulation error
  std::vector<double> history;        ///< loss after each iteration (history[0] = initial)
  bool converged = false;
  std::string stop_reason;            ///< "converged", "max_iterations", "no_descent"
};

/// Minimises V = (1/N)·Σ (y(k) − ŷ(k))², ŷ = B(q)/A(q)·u, starting from `initial` (whose orders and nk
/// are kept). Gradients are exact: ∂ŷ/∂b_j = q^(−nk−j)/A(q)·u and ∂ŷ/∂a_i = −q^(−i)/A(q)·ŷ. A step that
/// would put a pole outside the circle of radius 1 − margin is rejected and the damping raised, so the
/// result is stable. An unstable `initial` has its unstable poles reflected inside first. The Jacobian
/// is N×P (P parameters), never N×P×P. Throws EstimationError for unusable data.
OeResult estimate_oe(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const TransferFunction& initial,
                     const OeOptions& options = {});

/// The exact sensitivities of the simulated output ŷ = B(q)/A(q)·u (model at rest before sample 0) to
/// θ = [a_1 … a_na, b_0 … b_{nb−1}] at `tf`: an N×P matrix whose column i−1 is ∂ŷ/∂a_i = −q^(−i)/A(q)·ŷ
/// and column na+j is ∂ŷ/∂b_j = q^(−nk−j)/A(q)·u. The gradient of V is −(2/N)·Jᵀ(y − ŷ).
Eigen::MatrixXd oe_jacobian(const Eigen::VectorXd& u, const TransferFunction& tf);

/// `tf` with every pole outside radius 1 − margin reflected to 1/conj(p) (shrunk inside the margin).
/// B is kept as it is, so the response keeps its shape where only reflection was needed but its
/// magnitude is multiplied by Π|p| over the reflected poles (|e^{jω} − p| = |p|·|e^{jω} − 1/p̄|);
/// a stable `tf` is returned unchanged.
TransferFunction stabilized(const TransferFunction& tf, double margin = 1e-6);

}  // namespace panelbass::models

#pragma once
// Levenberg–Marquardt on normal equations that the caller accumulates: one damped step solves
// (H + damping(λ, H))·δ = g for H ≈ JᵀJ, g = dV/dθ ∝ Jᵀ(ŷ − y), tries θ − δ, and keeps it if the loss falls.
//
// Eigen's unsupported LevenbergMarquardt does not fit here: it wants a functor that returns the residual
// vector and its N×P Jacobian (or one row at a time through its storage-saving variant) and owns the loss,
// whereas the trainers build H and g blockwise from sensitivities they compute in their own sweeps
// (never storing N×P×P), mask pruned parameters, and reject a candidate for reasons of their own (an
// unstable OE denominator) before its loss is ever formed.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace panelbass::models {

/// What is added to the diagonal of H to damp a step (each the Marquardt scaling λ·diag(H), floored so
/// that an unexcited parameter, a zero row and column of H, still gets a definite system and a zero step).
/// The trainers were written with these three; their results depend on the last bits of the floor, so
/// each keeps its own (see models/optimization/README.md).
enum class LmDamping {
  /// λ·max(H_ii, 1e-12·max_j H_jj): a floor relative to the largest diagonal entry (OE).
  relative_to_largest,
  /// λ·(H_ii + 1e-9·mean_j H_jj): a floor relative to the mean diagonal entry (neural feedback).
  relative_to_mean,
  /// relative_to_mean plus the fixed ridge 1e-12·(1 + max_j H_jj), independent of λ (NARX).
  relative_to_mean_with_ridge,
};

/// How λ moves, and how often a step is retried before the optimiser gives up.
struct LmSettings {
  LmDamping damping = LmDamping::relative_to_mean;               ///< what λ multiplies, and its floor
  double initial_lambda = 1e-3;                                  ///< λ at the start and after reset()
  double min_lambda = 1e-12;                                     ///< λ ÷ factor stops here after a success
  double max_lambda = std::numeric_limits<double>::infinity();   ///< λ × factor stops here after a failure
  double factor = 10.0;                                          ///< λ ÷ factor on success, × factor on failure
  int retries = 12;                                              ///< damped solves per step before giving up
};

/// The outcome of one damped step.
struct LmStep {
  bool accepted = false;  ///< θ moved to θ − δ and the loss fell
  double loss = 0.0;      ///< the loss at the (new) θ: the trial's when accepted, the given V otherwise
};

/// The Levenberg–Marquardt state (λ) with the scratch space of its damped solves, sized once for P
/// parameters so that a step allocates nothing.
class LevenbergMarquardt {
 public:
  /// λ starts at settings.initial_lambda; P is the number of parameters.
  LevenbergMarquardt(const LmSettings& settings, Eigen::Index parameters);

  /// The current damping λ.
  double lambda() const { return lambda_; }
  /// λ back to settings.initial_lambda (a new phase of training).
  void reset() { lambda_ = settings_.initial_lambda; }
  /// The settings it runs with.
  const LmSettings& settings() const { return settings_; }

  /// One damped step from θ at loss V with Gauss–Newton matrix H (symmetric, P×P) and gradient g = dV/dθ
  /// (in any consistent scaling of H and g): up to settings.retries times, solves (H + damping)·δ = g,
  /// zeroes δ where `mask` is 0 (an empty mask frees every parameter), and asks trial(θ − δ) for the loss
  /// there (+∞ to reject the candidate, e.g. as unstable). The first candidate with a finite loss below V
  /// replaces θ and λ falls ÷ factor (to min_lambda); each failure raises λ × factor (to max_lambda). A
  /// non-finite δ is rejected without calling trial. Non-finite V, g or H: no step, λ unchanged.
  template <class Trial>
  LmStep step(const Eigen::MatrixXd& H, const Eigen::VectorXd& g, double V, Eigen::VectorXd& theta, Trial&& trial,
              const Eigen::VectorXd& mask = Eigen::VectorXd()) {
    if (!std::isfinite(V) || !g.allFinite() || !H.allFinite()) return {false, V};
    prepare_damping(H);
    for (int attempt = 0; attempt < settings_.retries; ++attempt) {
      solve_damped(H, g, mask);
      double V_new = std::numeric_limits<double>::infinity();
      if (delta_.allFinite()) {
        candidate_ = theta - delta_;
        V_new = trial(std::as_const(candidate_));
      }
      if (std::isfinite(V_new) && V_new < V) {
        theta = candidate_;
        lambda_ = std::max(lambda_ / settings_.factor, settings_.min_lambda);
        return {true, V_new};
      }
      lambda_ = std::min(lambda_ * settings_.factor, settings_.max_lambda);
    }
    return {false, V};
  }

 private:
  /// The λ-independent parts of the damping for this H (its floor and ridge).
  void prepare_damping(const Eigen::MatrixXd& H);
  /// δ = (H + damping(λ))⁻¹·g through LDLT, then zeroed where the mask is 0.
  void solve_damped(const Eigen::MatrixXd& H, const Eigen::VectorXd& g, const Eigen::VectorXd& mask);

  LmSettings settings_;
  double lambda_;
  Eigen::VectorXd scale_;      ///< relative_to_largest: max(H_ii, floor), what λ multiplies
  double floor_ = 0.0;         ///< relative_to_mean(_with_ridge): 1e-9·mean H_ii
  double ridge_ = 0.0;         ///< relative_to_mean_with_ridge: 1e-12·(1 + max H_ii)
  Eigen::MatrixXd damped_;     ///< H + damping
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
  Eigen::VectorXd delta_;
  Eigen::VectorXd candidate_;  ///< θ − δ
};

}  // namespace panelbass::models

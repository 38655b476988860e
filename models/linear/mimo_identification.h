#pragma once
// Identification of a multi-input multi-output linear state space from periodic steady-state data, end to
// end: the thesis's FIR → Hankel → OE route (fig. 4.1) made MIMO — Markov parameters by least squares on
// circular regressors, Kung's realisation of their block Hankel matrix, then Levenberg–Marquardt on the
// steady-state simulation error, keeping the iterate of lowest validation J.

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "models/linear/mimo_oe_estimator.h"
#include "models/linear/mimo_state_space.h"

namespace panelbass::models {

/// What identify_mimo fits.
struct MimoIdentificationSpec {
  int order = 0;               ///< states; 0 = at the largest gap of the Hankel singular values (up to max_auto_order)
  int max_auto_order = 60;     ///< the automatic order's upper bound
  Eigen::Index taps = 150;     ///< Markov parameters estimated (the FIR length)
  double ridge = 1e-6;         ///< the FIR's ridge, relative to the normal matrix's mean diagonal
  int max_iterations = 100;    ///< Levenberg–Marquardt steps at most (0: Kung's model as it is)
  /// Called after every refinement iteration; false stops it (the best iterate is kept).
  std::function<bool(const MimoRefinementRecord&)> progress;
};

/// The identified model in raw units and how it got there.
struct MimoIdentification {
  MimoStateSpace model;                 ///< from raw inputs to raw outputs
  int order = 0;                        ///< states
  Eigen::VectorXd hankel_singular_values;
  double kung_j_est_pct = 0.0;          ///< steady-state J of Kung's model (after modal stabilisation), estimation
  double kung_j_val_pct = 0.0;          ///< … and validation (estimation when there is none)
  MimoRefinement refinement;            ///< the Levenberg–Marquardt history (its model in scaled units)
};

/// Identifies from realisations u_est[r] (N×m) / y_est[r] (N×p), one steady-state period each (average a
/// realisation's periods first), selecting on u_val / y_val (may be empty: then on the estimation data).
/// Inputs and outputs are scaled by their overall RMS inside (the model is returned in raw units).
/// Throws std::invalid_argument for mismatched shapes, taps too few for the order, or a silent channel.
MimoIdentification identify_mimo(const std::vector<Eigen::MatrixXd>& u_est, const std::vector<Eigen::MatrixXd>& y_est,
                                 const std::vector<Eigen::MatrixXd>& u_val, const std::vector<Eigen::MatrixXd>& y_val,
                                 const MimoIdentificationSpec& spec);

/// The order at the largest ratio σ_n/σ_{n+1} of consecutive Hankel singular values, n ≤ max_order.
int order_from_singular_values(const Eigen::VectorXd& sigma, int max_order);

}  // namespace panelbass::models

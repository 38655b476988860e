#pragma once
// Bayesian regularisation: the weight decay that MacKay's evidence approximation asks for, from the
// Gauss–Newton matrix a Levenberg–Marquardt trainer already holds (MacKay 1992, "A practical Bayesian framework
// for backpropagation networks"; Foresee & Hagan 1997, the update of MATLAB's trainbr).

#include <Eigen/Core>

namespace panelbass::models {

/// One evidence update of the weight decay D of the criterion (Σ e² + D·‖θ‖²)/2, for a fit of `samples`
/// residuals: D_new = γ·Σe² / ((samples − γ)·‖θ‖²), γ = P − D·tr((JᵀJ + D·I)⁻¹) the effective number of
/// parameters (the noise variance over the weights' prior variance). `regularised` is JᵀJ + D·I (P×P,
/// symmetric), `squared_error` Σe², `mask` as LevenbergMarquardt's (0 = held: that row, column and θ entry left
/// out; empty = all free). Returns D unchanged when the update is not defined (a matrix not positive definite,
/// θ = 0, γ ≥ samples, a non-finite figure).
double evidence_weight_decay(const Eigen::MatrixXd& regularised, double squared_error, double samples, double D,
                             const Eigen::VectorXd& theta, const Eigen::VectorXd& mask = Eigen::VectorXd());

}  // namespace panelbass::models

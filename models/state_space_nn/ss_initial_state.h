#pragma once
// The initial state estimated per record (issue #36, item 3's alternative to SUBNET's encoder): x(0) chosen so
// that the model's own free run matches a record's first measured outputs, weighed against a Gaussian prior
// of its states — a maximum a posteriori estimate through the model's nonlinearity, where the encoder is an
// affine map of the past data. Where the output saturates, the states before the saturation do not show in
// the samples the encoder reads, and its transient lasts tens of samples; the fit sees them through the model.

#include <Eigen/Core>

#include "models/state_space_nn/ss_model.h"

namespace panelbass::models {

/// The prior of `m`'s states along raw data u, y: the free run from the encoder's state at sample `init`,
/// the states and output error of its samples from init + 2L on (past the encoder's transient) — their mean,
/// covariance and mean squared error (scaled units, where the output is of size one: the error floored at
/// 1e-12, so that a model exact on its data still weighs its prior). Throws
/// std::invalid_argument for mismatched lengths or fewer than nx + 2 samples past the transient.
SsStatePrior ss_state_prior(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init);

/// x(0) of scaled data us, ys for `m` (which must carry a state_prior): the minimiser of
/// Σ_{k<init} (ys(k) − ŷ(k))² / σ² + (x − μ)ᵀ Σ⁻¹ (x − μ), ŷ the free run from x at k = 0, by Eigen's
/// Levenberg–Marquardt (MINPACK's, forward-difference Jacobian) from x = μ; Σ floored by 1e-9 of its mean
/// variance (the states of an average are nearly collinear). A run whose fit leaves a non-finite output keeps
/// x = μ. Throws std::invalid_argument without a prior or with fewer than `init` samples.
Eigen::VectorXd ss_fit_initial_state(const SsModel& m, const Eigen::VectorXd& us, const Eigen::VectorXd& ys, Eigen::Index init);

}  // namespace panelbass::models

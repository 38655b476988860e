#pragma once
// Kung's realisation: a low-order state space from the SVD of an impulse response's Hankel matrix
// (the middle step of thesis fig. 4.1).

#include <Eigen/Core>

#include "models/linear/state_space.h"

namespace panelbass::models {

/// Kung's realisation: a state-space model of `order` states whose Markov parameters approximate
/// `impulse` (impulse[0] = D, impulse[k] = C·A^(k−1)·B), from the SVD of their Hankel matrix.
/// `singular_values` (optional) receives the Hankel singular values.
StateSpace hankel_reduction(const Eigen::VectorXd& impulse, int order, Eigen::VectorXd* singular_values = nullptr);

}  // namespace panelbass::models

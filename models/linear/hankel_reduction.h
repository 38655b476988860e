#pragma once
// Kung's realisation: a low-order state space from the SVD of an impulse response's (block) Hankel matrix
// (the middle step of thesis fig. 4.1), for p×m Markov parameters; the single-input single-output case is
// the 1×1 case of the same computation.

#include <Eigen/Core>
#include <vector>

#include "models/linear/mimo_state_space.h"
#include "models/linear/state_space.h"

namespace panelbass::models {

/// Kung's realisation: a state-space model of `order` states whose Markov parameters approximate
/// `markov` (markov[0] = D, markov[k] = C·A^(k−1)·B, each p×m), from the SVD of their block Hankel matrix.
/// `singular_values` (optional) receives the Hankel singular values. Needs at least 2·order + 1 Markov
/// parameters after D (one block row more than ⌈order/p⌉ for the shift); throws std::invalid_argument otherwise,
/// or for order < 1, non-finite or unequally shaped parameters.
MimoStateSpace kung_realization(const std::vector<Eigen::MatrixXd>& markov, int order,
                                Eigen::VectorXd* singular_values = nullptr);

/// Kung's realisation of a single-input single-output impulse response (impulse[0] = D,
/// impulse[k] = C·A^(k−1)·B): kung_realization with 1×1 blocks.
StateSpace hankel_reduction(const Eigen::VectorXd& impulse, int order, Eigen::VectorXd* singular_values = nullptr);

}  // namespace panelbass::models

#pragma once
// A model's own checks, in one place for every caller: a linear model's poles, an LQ controller's closed
// loop, and the bounded free run that stands in for a stability proof of a network (a NARX model, and a
// neural feedback controller in closed loop with its plant model). Each returns what it found; the caller
// words the refusal.

#include <Eigen/Core>
#include <optional>

#include "models/control/neural_feedback.h"
#include "models/linear/stability.h"
#include "models/linear/transfer_function.h"
#include "models/narx/free_run.h"
#include "models/narx/narx_model.h"

namespace panelbass::models {

// unstable_pole (linear/stability.h) and the free run (narx/free_run.h) are the kinds' own checks,
// which their loaders take too; here they stand beside the checks that need more than one kind.

/// The spectral radius of A − B·Lᵀ (the LQ controller's loop x(k+1) = (A − B·Lᵀ)·x(k) + B·u(k), in extended
/// precision) when it is not below 1; nullopt when the loop is stable. Sizes must agree (n×n, n, n).
std::optional<double> unstable_lq_radius(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, const Eigen::VectorXd& L);

/// The runaway of controller `c` in closed loop with its plant model (fig. 7.10) on free_run_drive() as the
/// program, measured in the plant's scaled output; nullopt when it stays bounded.
std::optional<Runaway> closed_loop_runaway(const NeuralFeedback& c);

}  // namespace panelbass::models

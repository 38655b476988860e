#pragma once
// A model's own checks, in one place for every caller: a linear model's poles, an LQ controller's closed
// loop, and the bounded free run that stands in for a stability proof of a network (a NARX model, and a
// neural feedback controller in closed loop with its plant model). Each returns what it found; the caller
// words the refusal. The `*_unsafety` functions read a model file object leniently, before its kind's
// loader, so that an unsafe model (it parses, but runs away) is told from a malformed one.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>

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

/// The key path of the first non-finite number in `root` (depth first, object keys in their stored order),
/// with that number; an explicit stack, so that a deeply nested file cannot overflow the thread's stack.
std::optional<std::pair<std::string, double>> first_non_finite(const nlohmann::json& root, const std::string& root_path);

/// A runaway of a free run as a problem of the model at `path` ("model: unstable: the free run on uniform
/// noise leaves ±100 output ranges (…)"); nullopt when `run` is.
std::optional<std::string> runaway_problem(const std::optional<Runaway>& run, const std::string& path, const std::string& what);

/// A linear model file's poles (roots of z^na·A(z)) outside the unit circle, as a problem; nullopt when stable or
/// unreadable (the loader names what is malformed).
std::optional<std::string> linear_unsafety(const nlohmann::json& file);

/// An LQ feedforward file's loop A − B·L unstable, as a problem; nullopt when stable or unreadable.
std::optional<std::string> lq_unsafety(const nlohmann::json& file);

/// A NARX model file (at `path`: "model", or "model.plant" inside a neural feedback file) whose free run on
/// uniform noise over its scaled input range leaves 100 output ranges, as a problem; nullopt otherwise.
std::optional<std::string> narx_unsafety(const nlohmann::json& file, const std::string& path = "model");

}  // namespace panelbass::models

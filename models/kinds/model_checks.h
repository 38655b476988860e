#pragma once
// A model's own checks, in one place for every caller: a linear model's poles, an LQ controller's closed
// loop, and the bounded free run that stands in for a stability proof of a network (a NARX model, and a
// neural feedback controller in closed loop with its plant model). Each returns what it found; the caller
// words the refusal.

#include <Eigen/Core>
#include <optional>

#include "models/control/neural_feedback.h"
#include "models/linear/transfer_function.h"
#include "models/narx/narx_model.h"

namespace panelbass::models {

/// Samples of a network's free run.
inline constexpr Eigen::Index kFreeRunSamples = 2000;
/// How far (scaled output units, where the identification data spans [−1, 1]) a free run may wander.
inline constexpr double kFreeRunBound = 100.0;

/// A pole on or outside the unit circle.
struct UnstablePole {
  double radius = 0.0;  ///< |z|
  double hz = 0.0;      ///< its frequency |arg z|·fs/2π (NaN when fs is)
};

/// The pole of `tf` farthest from the origin when it is not strictly inside the unit circle; nullopt
/// when `tf` is stable (an FIR always is).
std::optional<UnstablePole> unstable_pole(const TransferFunction& tf, double fs);

/// The spectral radius of A − B·Lᵀ (the LQ controller's loop x(k+1) = (A − B·Lᵀ)·x(k) + B·u(k), in extended
/// precision) when it is not below 1; nullopt when the loop is stable. Sizes must agree (n×n, n, n).
std::optional<double> unstable_lq_radius(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, const Eigen::VectorXd& L);

/// The drive of every free run: kFreeRunSamples of uniform noise over the scaled input range [−1, 1],
/// the same every time (the NARX loader's seed, so that both free runs agree).
Eigen::VectorXd free_run_drive();

/// Where a scaled output record first left ±kFreeRunBound or stopped being finite.
struct Runaway {
  Eigen::Index samples = 0;  ///< samples run up to and including the first one out of bounds
  double magnitude = 0.0;    ///< |y| there (NaN when not finite)
};

/// The first sample of `y_scaled` that is not finite or beyond ±kFreeRunBound; nullopt when none is.
std::optional<Runaway> runaway(const Eigen::VectorXd& y_scaled);

/// The runaway of `m`'s free run (scaled units) on free_run_drive(); nullopt when it stays bounded.
std::optional<Runaway> free_run_runaway(const NarxModel& m);

/// The runaway of controller `c` in closed loop with its plant model (fig. 7.10) on free_run_drive() as the
/// program, measured in the plant's scaled output; nullopt when it stays bounded.
std::optional<Runaway> closed_loop_runaway(const NeuralFeedback& c);

}  // namespace panelbass::models

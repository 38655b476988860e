#pragma once
// The bounded free run that stands in for a stability proof of a network: the same full-scale uniform
// noise (scaled units) every time, and the first sample that leaves the bound. The NARX loader, the API's
// validation and the closed-loop check of a neural feedback controller all run it.

#include <Eigen/Core>
#include <optional>

#include "models/narx/narx_model.h"

namespace panelbass::models {

/// Samples of a network's free run.
inline constexpr Eigen::Index kFreeRunSamples = 2000;
/// How far (scaled output units, where the identification data spans [−1, 1]) a free run may wander.
inline constexpr double kFreeRunBound = 100.0;

/// The drive of every free run: kFreeRunSamples of uniform noise over the scaled input range [−1, 1], the
/// same every time (a fixed seed).
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

}  // namespace panelbass::models

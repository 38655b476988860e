#pragma once
// The performance figure J of the thesis ([2A]): the share of the measured output's energy that a
// model's output misses.

#include <Eigen/Core>

namespace panelbass::models {

/// [2A] J = Σ (y_model − y)² / Σ y², in percent, over samples [start, end). Throws std::invalid_argument
/// for unequal lengths, an empty range, a zero-energy y, or a non-finite model output.
double j_percent(const Eigen::VectorXd& y_model, const Eigen::VectorXd& y, Eigen::Index start = 0);

}  // namespace panelbass::models

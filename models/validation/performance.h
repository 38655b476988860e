#pragma once
// The performance figures of the thesis: J ([2A]), the share of the measured output's energy that a
// model's output misses, and J_c ([2C]), the share of the desired output's energy that a controlled
// system's output misses. Both on the signals as given: offset correction is preprocessing (ch. 3),
// done to a recording before it is compared, never inside a figure.

#include <Eigen/Core>

namespace panelbass::models {

/// [2A] J = Σ (y_model − y)² / Σ y², in percent, over samples [start, end). Throws std::invalid_argument
/// for unequal lengths, an empty range, a zero-energy y, or a non-finite model output.
double j_percent(const Eigen::VectorXd& y_model, const Eigen::VectorXd& y, Eigen::Index start = 0);

/// [2C] J_c = Σ (y_desired − y)² / Σ y_desired² in percent, over k ≥ skip; with `weight`, each term times
/// w(k). Throws std::invalid_argument for unequal lengths, a weight count that differs, nothing left after
/// the skip, or a zero desired output.
double jc_percent(const Eigen::VectorXd& y, const Eigen::VectorXd& y_desired, Eigen::Index skip = 0,
                  const Eigen::VectorXd& weight = {});

}  // namespace panelbass::models

#pragma once
// Frequency grids for responses and plots.

#include <Eigen/Core>
#include <cmath>

namespace panelbass::dsp {

/// `count` frequencies from `lo` to `hi` (Hz, both > 0), equally spaced on a log scale, ends included.
inline Eigen::VectorXd log_spaced(double lo, double hi, Eigen::Index count) {
  return Eigen::VectorXd::LinSpaced(count, std::log(lo), std::log(hi)).array().exp();
}

}  // namespace panelbass::dsp

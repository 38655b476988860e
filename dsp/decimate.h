#pragma once
// Zero-phase decimation of a recorded signal by an integer factor.

#include <Eigen/Core>

namespace panelbass::dsp {

/// `x` low-pass filtered (Butterworth, order 8, forward and backward so no phase is added, cutoff
/// 0.8·fs/(2·factor)) and kept every `factor`-th sample. Throws std::invalid_argument for factor < 1.
Eigen::VectorXd decimate(const Eigen::VectorXd& x, int factor);

}  // namespace panelbass::dsp

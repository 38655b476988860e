#pragma once
// The leaky integral of a signal: velocity from an accelerometer, bounded where a true integral drifts.

#include <Eigen/Core>

namespace panelbass::dsp {

/// x_int(k) = λ·x_int(k−1) + x(k)/fs with λ = exp(−2π·corner_hz/fs): an integrator above its corner
/// (fs/500 when corner_hz is 0), so a DC part or slow wander stays bounded. Starts at rest; empty in, empty out.
Eigen::VectorXd leaky_integral(const Eigen::VectorXd& x, double fs, double corner_hz = 0.0);

}  // namespace panelbass::dsp

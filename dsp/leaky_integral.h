#pragma once
// The leaky integral of a signal: velocity from an accelerometer, bounded where a true integral drifts.

#include <Eigen/Core>

namespace panelbass::dsp {

/// x_int(k) = λ·x_int(k−1) + x(k)/fs with λ = exp(−2π/500): an integrator above its corner fs/500, so a
/// DC part or slow wander stays bounded. Starts at rest; empty in, empty out.
Eigen::VectorXd leaky_integral(const Eigen::VectorXd& x, double fs);

}  // namespace panelbass::dsp

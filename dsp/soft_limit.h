#pragma once
// The soft limiter that keeps a drive within [−1, 1]: linear up to a knee, then a tanh compression
// towards the rails. The engine's safety limiter and the neural feedback controller's bounded output
// both use it.

namespace panelbass::dsp {

/// v for |v| ≤ knee, else sign(v)·(knee + (1 − knee)·tanh((|v| − knee)/(1 − knee))): continuous with a
/// continuous slope ≤ 1, within [−1, 1] for every finite v; 0 for a non-finite v. knee in [0, 1).
double soft_limit(double v, double knee) noexcept;

/// d soft_limit(v, knee)/dv: 1 below the knee, 1 − tanh²((|v| − knee)/(1 − knee)) above it; 0 for a
/// non-finite v.
double soft_limit_slope(double v, double knee) noexcept;

}  // namespace panelbass::dsp

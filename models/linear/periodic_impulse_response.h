#pragma once
// The p×m impulse response (Markov parameters) of a multi-input multi-output system from periodic data in
// steady state: least squares on circular regressors, the FIR step of the thesis's FIR → Hankel route
// (fig. 4.1) made MIMO.

#include <Eigen/Core>
#include <vector>

namespace panelbass::models {

/// The Markov parameters g_0..g_{taps−1} (each p×m) minimising Σ_r Σ_t |y_r(t) − Σ_k g_k·u_r((t − k) mod N)|²
/// over realisations r, where u[r] (N×m) and y[r] (N×p) are one steady-state period each (the periods of a
/// realisation averaged): the regressors wrap around the period, so no sample is lost to the start.
/// The normal equations are built from circular correlations (FFT), never from the N×(m·taps) regressors.
/// With `ridge` > 0, ridge·(mean diagonal) is added to them: lags and input directions the band-limited
/// excitation does not reach get no response instead of a singular system. Exact for a system whose impulse
/// response has died out within `taps` samples. Throws std::invalid_argument for mismatched shapes,
/// taps < 1 or taps > N, non-finite data, or (ridge 0) an input that does not excite m·taps directions.
std::vector<Eigen::MatrixXd> estimate_periodic_impulse_response(const std::vector<Eigen::MatrixXd>& u,
                                                                const std::vector<Eigen::MatrixXd>& y,
                                                                Eigen::Index taps, double ridge = 0.0);

}  // namespace panelbass::models

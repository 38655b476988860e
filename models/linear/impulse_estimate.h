#pragma once
// Dead time and impulse-response length read off the input/output correlation (thesis ch. 3: with a
// white input the cross-correlation approximates the impulse response).

#include <Eigen/Core>

namespace panelbass::models {

/// What the cross-correlation of a white input with the output says about the system.
struct ImpulseEstimate {
  int delay = 0;               ///< leading lags inside the 99.9 % noise band or below 5 % of the peak; 0 when
                               ///< no lag of the first half stands out (delay_found false)
  bool delay_found = false;    ///< a lag of the first half (where the response must lie) stood out of the noise
  int length = 0;              ///< lag after which the correlation has sunk into its noise band for good
  double noise_band = 0.0;     ///< 99.9 % half-width of the noise band, normalised correlation units
  Eigen::VectorXd response;    ///< impulse response scaled by σ_u/σ_y (the cross-correlation corrected
                               ///< for the input's sample autocorrelation), lags 0..max_lag
};

/// Estimates delay and impulse length from `u` (white) and `y`, looking at lags 0..max_lag (≥ 40; the
/// second half of them must hold only noise, whose level is measured there; N ≥ 2·(max_lag+1)). The length ends the last
/// window of 20 lags whose RMS exceeds three times the noise's; single stray lags outside the band do not count.
ImpulseEstimate estimate_impulse(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index max_lag);

}  // namespace panelbass::models

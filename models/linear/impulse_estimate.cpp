#include "models/linear/impulse_estimate.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "models/linear/fir_estimator.h"

namespace panelbass::models {

ImpulseEstimate estimate_impulse(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index max_lag) {
  if (max_lag < 40) throw std::invalid_argument("impulse estimate: look at 40 lags or more");
  if (u.size() != y.size()) throw std::invalid_argument("impulse estimate: input and output lengths differ");
  ImpulseEstimate e;
  // The raw cross-correlation r_uy = h * r̂_uu carries the input's sample autocorrelation (≈ 1/√N off
  // lag 0) smeared by a resonant h: bursts long after the response has died. Least squares divides
  // r̂_uu out exactly, leaving only what the output's noise and distortion put in. An input that leaves the
  // normal equations singular (a multisine, empty outside its band) gets a ridge of 1e-3 instead: no
  // response where it has no power, the least-squares one where it has.
  const Eigen::VectorXd uc = u.array() - u.mean();
  const Eigen::VectorXd yc = y.array() - y.mean();
  if (!(uc.squaredNorm() > 0.0) || !(yc.squaredNorm() > 1e-24 * y.squaredNorm()) || !(yc.squaredNorm() > 0.0)) {
    throw std::invalid_argument("impulse estimate: the input or the output is constant");
  }
  const double std_ratio = std::sqrt(uc.squaredNorm() / yc.squaredNorm());
  Eigen::VectorXd fir;
  try {
    fir = estimate_fir(uc, yc, max_lag + 1);
  } catch (const std::invalid_argument&) {
    fir = estimate_fir(uc, yc, max_lag + 1, 1e-3);  // singular; a record too short throws here again
  }
  e.response = fir * std_ratio;
  const Eigen::VectorXd& r = e.response;

  // Its noise level is measured on the second half of the lags, where only noise is assumed (a floor
  // far below the response keeps a noise-free record from chasing rounding errors).
  const Eigen::Index tail = max_lag / 2;
  const double tail_rms = std::sqrt(r.tail(max_lag + 1 - tail).squaredNorm() / static_cast<double>(max_lag + 1 - tail));
  const double sigma = std::max(tail_rms, 1e-9 * r.cwiseAbs().maxCoeff());
  e.noise_band = 3.29 * sigma;  // 99.9 % two-sided for a Gaussian estimate

  // Dead time ends at the first lag standing out of the noise and above 5 % of the peak: the first
  // sample after a converter step carries ~1 % of the response through the analog filters, which no
  // one reading the correlation would call a response.
  // Only the first half can hold it: the second half is taken for noise. When nothing there stands out
  // (a coloured input whose normal equations spread noise over every lag, a record of noise alone), the
  // correlation says nothing about dead time and none is assumed, rather than the window's length.
  const double visible = std::max(e.noise_band, 0.05 * r.cwiseAbs().maxCoeff());
  while (e.delay < tail && std::abs(r[e.delay]) <= visible) ++e.delay;
  e.delay_found = e.delay < tail;
  if (!e.delay_found) e.delay = 0;

  // The response has ended where windows of kWindow lags hold no more than three times the noise's RMS.
  constexpr Eigen::Index kWindow = 20;
  Eigen::Index last_window = -1;
  for (Eigen::Index start = 0; start + kWindow <= tail; ++start) {
    if (std::sqrt(r.segment(start, kWindow).squaredNorm() / kWindow) > 3.0 * sigma) last_window = start;
  }
  // It ends at the last lag of that window that still stands outside the 99 % band.
  e.length = e.delay;
  for (Eigen::Index tau = last_window; last_window >= 0 && tau < last_window + kWindow; ++tau) {
    if (std::abs(r[tau]) > 2.58 * sigma) e.length = std::max(e.length, static_cast<int>(tau + 1));
  }
  return e;
}

}  // namespace panelbass::models

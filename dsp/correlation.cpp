#include "dsp/correlation.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace panelbass::dsp {
namespace {

// Inverse of the standard normal CDF by bisection on erfc: plenty accurate for confidence levels.
double normal_quantile(double p) {
  double lo = -10.0, hi = 10.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

Eigen::VectorXd cross_correlation(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index max_lag) {
  const Eigen::Index n = u.size();
  if (y.size() != n) throw std::invalid_argument("cross-correlation: signals of unequal length");
  if (max_lag < 0 || max_lag >= n) {
    throw std::invalid_argument("cross-correlation: max lag " + std::to_string(max_lag) + " must be below " +
                                std::to_string(n) + " samples");
  }
  const Eigen::VectorXd uc = u.array() - u.mean();
  const Eigen::VectorXd yc = y.array() - y.mean();
  const double scale = std::sqrt(uc.squaredNorm() * yc.squaredNorm());
  if (!(scale > 0.0)) throw std::invalid_argument("cross-correlation: a signal is constant");
  Eigen::VectorXd r(max_lag + 1);
  for (Eigen::Index tau = 0; tau <= max_lag; ++tau) r[tau] = uc.head(n - tau).dot(yc.tail(n - tau)) / scale;
  return r;
}

Eigen::VectorXd autocorrelation(const Eigen::VectorXd& x, Eigen::Index max_lag) {
  return cross_correlation(x, x, max_lag);
}

double correlation_noise_band(Eigen::Index samples, double confidence) {
  if (samples < 1) throw std::invalid_argument("noise band: need samples");
  if (!(confidence > 0.0 && confidence < 1.0)) throw std::invalid_argument("noise band: confidence in (0, 1)");
  return normal_quantile(0.5 + confidence / 2.0) / std::sqrt(static_cast<double>(samples));
}

}  // namespace panelbass::dsp

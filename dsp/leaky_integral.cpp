#include "dsp/leaky_integral.h"

#include <cmath>
#include <numbers>

namespace panelbass::dsp {

Eigen::VectorXd leaky_integral(const Eigen::VectorXd& x, double fs, double corner_hz) {
  const double lambda = std::exp(-2.0 * std::numbers::pi * (corner_hz > 0.0 ? corner_hz / fs : 1.0 / 500.0));
  Eigen::VectorXd out(x.size());
  double s = 0.0;
  for (Eigen::Index k = 0; k < x.size(); ++k) out[k] = s = lambda * s + x[k] / fs;
  return out;
}

}  // namespace panelbass::dsp

#include "dsp/decibels.h"

#include <cmath>
#include <complex>
#include <limits>

namespace panelbass::dsp {

Eigen::VectorXd power_db(const Eigen::VectorXd& p) {
  return p.unaryExpr([](double v) { return v > 0.0 ? 10.0 * std::log10(v) : std::numeric_limits<double>::quiet_NaN(); });
}

Eigen::VectorXd magnitude_db(const Eigen::VectorXcd& h) {
  return h.unaryExpr([](std::complex<double> v) {
    return std::abs(v) > 0.0 ? 20.0 * std::log10(std::abs(v)) : std::numeric_limits<double>::quiet_NaN();
  });
}

}  // namespace panelbass::dsp

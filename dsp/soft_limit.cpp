#include "dsp/soft_limit.h"

#include <cmath>

namespace panelbass::dsp {

double soft_limit(double v, double knee) noexcept {
  if (!std::isfinite(v)) return 0.0;
  const double magnitude = std::abs(v);
  if (magnitude <= knee) return v;
  const double room = 1.0 - knee;
  // tanh reaches exactly 1.0 in double precision for large arguments: the result stays within [−1, 1]
  return std::copysign(knee + room * std::tanh((magnitude - knee) / room), v);
}

double soft_limit_slope(double v, double knee) noexcept {
  if (!std::isfinite(v)) return 0.0;
  const double magnitude = std::abs(v);
  if (magnitude <= knee) return 1.0;
  const double t = std::tanh((magnitude - knee) / (1.0 - knee));
  return 1.0 - t * t;
}

}  // namespace panelbass::dsp

#include "usecases/progress.h"

#include <algorithm>
#include <cmath>

namespace panelbass::usecases {

void ProgressSpan::report(double fraction, const std::string& message) {
  const double f = std::isfinite(fraction) ? std::clamp(fraction, 0.0, 1.0) : 0.0;
  outer_.report(lo_ + f * (hi_ - lo_), message);
}

}  // namespace panelbass::usecases

#include "api/jobs/job_progress.h"

#include <algorithm>
#include <cmath>

namespace panelbass::api {

void JobProgress::span(double lo, double hi) {
  lo_ = lo;
  hi_ = hi;
}

void JobProgress::at(double fraction, const std::string& message) {
  const double f = lo_ + (hi_ - lo_) * std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
  last_ = std::max(last_, f);
  control_.progress(last_, message);
}

}  // namespace panelbass::api

#include "models/oscillator/band_limited_input.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dsp/resample.h"

namespace panelbass::models {

BandLimitedInput::BandLimitedInput(const Eigen::VectorXd& u) : samples_(u) {
  if (u.size() == 0) throw std::invalid_argument("band-limited input: no samples");
  if (u.size() == 1) {
    grid_ = Eigen::VectorXd::Constant(1, u(0));
    return;
  }
  grid_ = dsp::resample(u, 1.0, kOversampling);
}

void BandLimitedInput::neighbours(double t, double p[4], double& fraction) const {
  const double x = std::clamp(t * kOversampling, 0.0, static_cast<double>(grid_.size() - 1));
  const double whole = std::floor(x);
  fraction = x - whole;
  const Eigen::Index j = static_cast<Eigen::Index>(whole), last = grid_.size() - 1;
  for (int i = 0; i < 4; ++i) p[i] = grid_(std::clamp<Eigen::Index>(j - 1 + i, 0, last));
}

double BandLimitedInput::value(double t) const {
  double p[4], a;
  neighbours(t, p, a);
  return p[1] + 0.5 * a * (p[2] - p[0] + a * (2 * p[0] - 5 * p[1] + 4 * p[2] - p[3] + a * (3 * (p[1] - p[2]) + p[3] - p[0])));
}

double BandLimitedInput::slope(double t) const {
  const double x = t * kOversampling;
  if (x <= 0.0 || x >= static_cast<double>(grid_.size() - 1)) return 0.0;  // held beyond the record
  double p[4], a;
  neighbours(t, p, a);
  const double per_grid_step =
      0.5 * (p[2] - p[0]) + a * (2 * p[0] - 5 * p[1] + 4 * p[2] - p[3]) + 1.5 * a * a * (3 * (p[1] - p[2]) + p[3] - p[0]);
  return per_grid_step * kOversampling;
}

}  // namespace panelbass::models

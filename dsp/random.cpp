#include "dsp/random.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace panelbass::dsp {

double Rng::gaussian() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  // Marsaglia polar method: a point uniform in the unit disc gives two independent normals,
  // x·sqrt(-2 ln s / s) and y·sqrt(-2 ln s / s); the second is kept for the next call.
  double x = 0.0;
  double y = 0.0;
  double s = 0.0;
  do {
    x = uniform(-1.0, 1.0);
    y = uniform(-1.0, 1.0);
    s = x * x + y * y;
  } while (s >= 1.0 || s == 0.0);
  const double factor = std::sqrt(-2.0 * std::log(s) / s);
  spare_ = y * factor;
  has_spare_ = true;
  return x * factor;
}

std::uint64_t Rng::below(std::uint64_t n) {
  if (n == 0) {
    throw std::invalid_argument("Rng::below: n must be > 0, got 0");
  }
  // 2^64 mod n raw values at the bottom are rejected, so the accepted range [threshold, 2^64)
  // holds a whole number of copies of [0, n) and r % n is exactly uniform.
  const std::uint64_t threshold = (std::numeric_limits<std::uint64_t>::max() - n + 1) % n;
  for (;;) {
    const std::uint64_t r = engine_();
    if (r >= threshold) {
      return r % n;
    }
  }
}

}  // namespace panelbass::dsp

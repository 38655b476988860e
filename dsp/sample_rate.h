#pragma once
// Sample rates compared the one way every layer compares them: equal to a part in 10⁹, so that a rate
// written to a file and read back, or computed as a ratio, still counts as the same.

#include <algorithm>
#include <cmath>

namespace panelbass::dsp {

/// True when rates `a` and `b` (Hz) agree to a part in 10⁹ of the larger; false for a NaN.
inline bool same_rate(double a, double b) noexcept {
  return std::abs(a - b) <= 1e-9 * std::max(std::abs(a), std::abs(b));
}

}  // namespace panelbass::dsp

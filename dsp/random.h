#pragma once
// The project's one source of randomness: seeded, and the same numbers on every platform.

#include <cstdint>
#include <random>

namespace panelbass::dsp {

/// A seeded random source. std::mt19937_64's sequence is fixed by the standard; the mappings to
/// uniform and Gaussian numbers are written out here because std's distributions are not portable.
class Rng {
 public:
  /// Starts the sequence for `seed`.
  explicit Rng(std::uint64_t seed) : engine_(seed) {}

  /// Uniform in [0, 1) with 53 random bits.
  double uniform01() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform01(); }

  /// Standard normal (Marsaglia polar method).
  double gaussian();

  /// Uniform integer in [0, n), n > 0 (rejection sampling, no modulo bias).
  std::uint64_t below(std::uint64_t n);

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace panelbass::dsp

#include "engine/safety_limiter.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace panelbass::engine {

SafetyLimiter::SafetyLimiter(const LimiterOptions& options) : options_(options) { validate(options); }

void SafetyLimiter::validate(const LimiterOptions& options) {
  if (!(options.knee >= 0.0 && options.knee < 1.0)) {
    throw std::invalid_argument("safety limiter: knee must be within [0, 1), got " + std::to_string(options.knee));
  }
  if (!(options.pinned_level > 0.0)) {
    throw std::invalid_argument("safety limiter: pinned_level must be > 0, got " +
                                std::to_string(options.pinned_level));
  }
  if (options.max_pinned.value < 0) {
    throw std::invalid_argument("safety limiter: max_pinned must be >= 0 samples, got " +
                                std::to_string(options.max_pinned.value));
  }
}

void SafetyLimiter::reset() noexcept {
  pinned_run_ = 0;
  trip_ = Fault::none;
}

}  // namespace panelbass::engine

#pragma once
// The safety limiter at the end of the chain: the drive never leaves [−1, 1] (the model's valid range),
// and a non-finite or runaway controller output is reported so the chain can drop to its safe bypass.

#include <cmath>

#include "dsp/soft_limit.h"
#include "engine/metrics.h"
#include "engine/stage.h"

namespace panelbass::engine {

/// Settings of the safety limiter.
struct LimiterOptions {
  double knee = 0.8;        ///< below this |drive| passes unchanged; above it is compressed towards 1
  double pinned_level = 1.0;  ///< an unlimited |drive| at or above this counts as pinned at the rails
  Samples max_pinned{300};  ///< consecutive pinned samples tolerated (0.1 s at 3000 Hz)
};

/// The soft limiter of dsp/soft_limit.h, in the engine's namespace.
using dsp::soft_limit;

/// soft_limit() plus the watch for non-finite values and a drive pinned at the rails.
class SafetyLimiter {
 public:
  /// A limiter with `options`; throws std::invalid_argument unless 0 ≤ knee < 1, pinned_level > 0
  /// and max_pinned ≥ 0.
  explicit SafetyLimiter(const LimiterOptions& options = {});

  /// The limited drive of `v`; sets tripped() when v is not finite or has been pinned too long. Inline: the
  /// chain calls it once per sample.
  double process(double v) noexcept {
    if (!std::isfinite(v)) {
      trip_ = Fault::non_finite_output;
      pinned_run_ = 0;
      return 0.0;
    }
    const double magnitude = std::abs(v);
    if (magnitude >= options_.pinned_level) {
      if (++pinned_run_ > options_.max_pinned.value) trip_ = Fault::pinned;
    } else {
      pinned_run_ = 0;
    }
    // soft_limit() passes v unchanged up to the knee; only above it is the call needed.
    return magnitude <= options_.knee ? v : soft_limit(v, options_.knee);
  }
  /// What tripped the limiter since the last take_trip() (Fault::none if nothing), and clears it.
  Fault take_trip() noexcept {
    const Fault f = trip_;
    trip_ = Fault::none;
    return f;
  }
  /// Audio thread: replaces the settings (validated by the control thread) and forgets the pinned run.
  void set_options(const LimiterOptions& options) noexcept {
    options_ = options;
    pinned_run_ = 0;
  }
  /// Throws std::invalid_argument unless `options` are valid (see the constructor).
  static void validate(const LimiterOptions& options);
  /// Forgets the pinned run (after a fault or when leaving the safe bypass).
  void reset() noexcept;
  /// The settings.
  const LimiterOptions& options() const { return options_; }

 private:
  LimiterOptions options_;
  int pinned_run_ = 0;
  Fault trip_ = Fault::none;
};

}  // namespace panelbass::engine

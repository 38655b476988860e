#pragma once
// The mirror filter (models/control/mirror_filter.h) as a feedforward stage of the chain: program in,
// the drive that makes the identified nonlinear exciter model move as its linear reference would, out.
// When the model carries observer settings (a sensor map), the stage also watches the sensor: an extended
// Kalman filter (models/control/mirror_observer.h) adapts the model's stiffness and the scale of its
// nonlinearity on line, so the filter's model — and its linear reference — follow a transducer that has moved.
// When they are for the coil current (issue #56), the stage's measurement is the current and a Kalman filter on the
// scales of the coil's resistance, Bl(x), K(x) and the nonlinear shapes (models/control/mirror_current_adapter.h)
// adapts the filter from the current's prediction error, every kScaleInterval samples.

#include <optional>

#include "engine/stage.h"
#include "models/control/mirror_current_adapter.h"
#include "models/control/mirror_filter.h"
#include "models/control/mirror_observer.h"

namespace panelbass::engine {

/// The mirror filter as a stage. A drive it asks for beyond the limiter's knee is the chain's limiter's to
/// report (its activity counters): the program needs more drive than the chain can give.
class MirrorFilterStage final : public Stage {
 public:
  /// The stage of `model` (adaptive when the model has observer settings).
  explicit MirrorFilterStage(const models::MirrorModel& model);
  /// Throws std::invalid_argument if spec.fs differs from the model's rate.
  void prepare(const ProcessSpec& spec) override;
  /// One program sample in, one drive sample out (the observer's time update with that drive).
  double process(double x) noexcept override;
  /// Samples between two settings of the filter's scales from the current adapter's estimates.
  static constexpr int kScaleInterval = 8;
  /// The sensor's output (or with a current adaptation, the coil current) for the sample just processed: the
  /// observer's (adapter's) update, and the filter's scales set to its estimates. An exact 0 (a chain run without a
  /// sensor) is no measurement: the filter keeps its scales.
  void observe(double measured) noexcept override;
  /// True when adaptive.
  bool observes() const noexcept override { return observer_.has_value() || adapter_.has_value(); }
  /// Back to rest (the adapted scales too).
  void reset() noexcept override;
  /// The observer, when the stage adapts (its estimates: scales(), state()).
  const models::MirrorObserver* observer() const { return observer_ ? &*observer_ : nullptr; }
  /// The current adapter, when the stage adapts from the coil current (its estimates: scales()).
  const models::MirrorCurrentAdapter* current_adapter() const { return adapter_ ? &*adapter_ : nullptr; }

 private:
  double fs_;
  models::MirrorFilter filter_;
  std::optional<models::MirrorObserver> observer_;
  std::optional<models::MirrorCurrentAdapter> adapter_;
  int since_scales_ = 0;  // samples since the filter's scales were last set from the adapter
};

}  // namespace panelbass::engine

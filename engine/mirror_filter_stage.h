#pragma once
// The mirror filter (models/control/mirror_filter.h) as a feedforward stage of the chain: program in,
// the drive that makes the identified nonlinear exciter model move as its linear reference would, out.

#include "engine/stage.h"
#include "models/control/mirror_filter.h"

namespace panelbass::engine {

/// The mirror filter as a stage. A drive it asks for beyond the limiter's knee is the chain's limiter's to
/// report (its activity counters): the program needs more drive than the chain can give.
class MirrorFilterStage final : public Stage {
 public:
  /// The stage of `model`.
  explicit MirrorFilterStage(const models::MirrorModel& model);
  /// Throws std::invalid_argument if spec.fs differs from the model's rate.
  void prepare(const ProcessSpec& spec) override;
  /// One program sample in, one drive sample out.
  double process(double x) noexcept override { return filter_.process(x); }
  /// Back to rest.
  void reset() noexcept override { filter_.reset(); }

 private:
  double fs_;
  models::MirrorFilter filter_;
};

}  // namespace panelbass::engine

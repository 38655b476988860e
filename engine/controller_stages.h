#pragma once
// The controllers of the Control issue as engine stages: the LQ feedforward controller ([7B], a
// state-space system u → u*) and the neural feedback controller (fig. 7.10), which reads the plant's
// output either from the sensor (observe()) or from its own plant model (NARX or state-space).

#include <Eigen/Core>
#include <memory>

#include "engine/sensor_watch.h"
#include "engine/stage.h"
#include "models/control/neural_feedback.h"
#include "models/linear/state_space_runner.h"

namespace panelbass::engine {

/// A SISO state-space system in raw units as a stage (the LQ feedforward controller's u → u*).
class StateSpaceStage final : public Stage {
 public:
  /// The stage of `system`, valid at sample rate `fs`; a ConfigError if it has more than kMaxStageStates.
  StateSpaceStage(models::StateSpace system, double fs);
  /// Sizes the state; throws if spec.fs differs from the system's rate or the matrices disagree in size.
  void prepare(const ProcessSpec& spec) override;
  /// y(k) = C·x(k) + D·u(k), x(k+1) = A·x(k) + B·u(k).
  double process(double x) noexcept override;
  /// A block of process() (StateSpaceRunner::step_block: the state kept in registers).
  void process_block(std::span<const double> in, std::span<double> out) noexcept override {
    runner_.step_block(in, out);
  }
  /// Ignores the plant.
  bool observes() const noexcept override { return false; }
  /// State to zero.
  void reset() noexcept override;

 private:
  models::StateSpace ss_;
  double fs_;
  models::StateSpaceRunner runner_;
};

/// The neural feedback controller as a stage: program (feedforward output) in, drive out.
class NeuralFeedbackStage final : public Stage {
 public:
  /// The stage of `controller`, its plant output taken from `source` (sensor: observe(); model: its
  /// plant model, NARX or state-space, run on the drives it produces).
  NeuralFeedbackStage(models::NeuralFeedback controller, FeedbackSource source);
  /// Sizes the runner; throws if spec.fs differs from the controller's rate.
  void prepare(const ProcessSpec& spec) override;
  /// v(k) = soft_limit(u(k) + N1(…)); in model mode, also steps the plant model.
  double process(double x) noexcept override;
  /// True in sensor mode.
  bool observes() const noexcept override { return source_ == FeedbackSource::sensor; }
  /// In sensor mode, the measured plant output becomes the newest past output — unless the sensor has
  /// gone silent (see SensorWatch), when the plant model's output stands in until it comes back.
  void observe(double measured) noexcept override;
  /// Every history to zero.
  void reset() noexcept override;
  /// Fault::sensor_lost once when the sensor went silent (the stage then runs on its plant model).
  Fault take_fault() noexcept override;
  /// The samples whose u + N1 was at or beyond full scale before the stage's soft limit, and the peak.
  StageDemand take_demand() noexcept override;
  /// True while a silent sensor is replaced by the plant model.
  bool on_model_fallback() const noexcept { return watch_.lost(); }

 private:
  models::NeuralFeedback controller_;
  FeedbackSource source_;
  std::unique_ptr<models::FeedbackRunner> runner_;
  SensorWatch watch_;
  double predicted_ = 0.0;     // the plant model's output for the sample just processed
  bool fault_pending_ = false;
  StageDemand demand_;         // since the last take_demand()
};

}  // namespace panelbass::engine

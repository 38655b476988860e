#include "engine/controller_stages.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/sample_rate.h"
#include "models/io/config_error.h"

namespace panelbass::engine {
namespace {

void require_rate(double model_fs, double fs, const char* stage) {
  if (!dsp::same_rate(model_fs, fs)) {
    throw std::invalid_argument(std::string(stage) + ": designed for " + std::to_string(model_fs) +
                                " Hz, the chain runs at " + std::to_string(fs) + " Hz");
  }
}

}  // namespace

StateSpaceStage::StateSpaceStage(models::StateSpace system, double fs) : ss_(std::move(system)), fs_(fs) {
  if (ss_.A.rows() > kMaxStageStates) {
    throw models::ConfigError("params: " + std::to_string(ss_.A.rows()) + " states are more than the engine runs (" +
                              std::to_string(kMaxStageStates) + ")");
  }
}

void StateSpaceStage::prepare(const ProcessSpec& spec) {
  require_rate(fs_, spec.fs, "state-space stage");
  models::check_shape(ss_, "state-space stage");
  runner_ = models::StateSpaceRunner(ss_);
}

double StateSpaceStage::process(double x) noexcept {
  // [7B] u*(k) = −L·x(k) + u(k), x(k+1) = (A − BL)·x(k) + B·u(k), as y = C·x + D·u, x ← A·x + B·u
  return runner_.step(x);
}

void StateSpaceStage::reset() noexcept { runner_.reset(); }

NeuralFeedbackStage::NeuralFeedbackStage(models::NeuralFeedback controller, FeedbackSource source)
    : controller_(std::move(controller)), source_(source) {}

void NeuralFeedbackStage::prepare(const ProcessSpec& spec) {
  require_rate(controller_.fs, spec.fs, "neural feedback stage");
  runner_ = std::make_unique<models::FeedbackRunner>(controller_);
  // A tenth of a second of silence while the model predicts signal: the sensor is lost.
  watch_ = SensorWatch({.silence = 1e-6, .timeout = std::max(1, static_cast<int>(std::lround(0.1 * spec.fs)))});
}

double NeuralFeedbackStage::process(double x) noexcept {
  const double v = runner_->control(x);
  const double asked = std::abs(runner_->asked());
  if (std::isfinite(asked)) {
    demand_.peak = std::max(demand_.peak, asked);
    if (asked >= 1.0) ++demand_.over_range;
  }
  // The plant model runs in both modes: it is the output in model mode, and the stand-in for a lost sensor.
  predicted_ = runner_->plant_model_output();
  if (source_ == FeedbackSource::model) runner_->push_output(predicted_);
  return v;
}

void NeuralFeedbackStage::observe(double measured) noexcept {
  if (source_ != FeedbackSource::sensor) return;
  if (watch_.update(measured, predicted_) && watch_.lost()) fault_pending_ = true;
  runner_->push_output(watch_.lost() ? predicted_ : measured);
}

void NeuralFeedbackStage::reset() noexcept {
  if (runner_) runner_->reset();
  watch_.reset();
  predicted_ = 0.0;
  demand_ = {};
}

StageDemand NeuralFeedbackStage::take_demand() noexcept {
  const StageDemand d = demand_;
  demand_ = {};
  return d;
}

Fault NeuralFeedbackStage::take_fault() noexcept {
  if (!fault_pending_) return Fault::none;
  fault_pending_ = false;
  return Fault::sensor_lost;
}

}  // namespace panelbass::engine

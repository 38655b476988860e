#pragma once
// A linear and a NARX plant model run as stages of the engine's chain. No slot of the engine runs a plant model
// (models/kinds/model_file.h: a slot takes a controller), so these are not the engine's: the engine's tests and
// its bench use them as simple stages with a known output (the model's own simulation) to exercise the chain,
// its slots, hot swaps, warm-up, sensor mode and the audio thread's allocations.

#include <Eigen/Core>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>

#include "dsp/sample_rate.h"
#include "engine/stage.h"
#include "models/io/config_error.h"
#include "models/linear/linear_model.h"
#include "models/linear/state_space_runner.h"
#include "models/narx/mlp_kernel.h"
#include "models/narx/narx_history.h"
#include "models/narx/narx_model.h"

namespace panelbass::engine {

namespace model_stages_detail {
// A model identified at another rate would run at the wrong speed: say so instead.
inline void require_rate(double model_fs, double fs, const char* stage) {
  if (!dsp::same_rate(model_fs, fs)) {
    throw std::invalid_argument(std::string(stage) + ": the model was identified at " + std::to_string(model_fs) +
                                " Hz, the chain runs at " + std::to_string(fs) + " Hz");
  }
}
}  // namespace model_stages_detail

/// A linear model as a stage: its state-space realisation run on raw input, giving raw output.
class LinearStage : public Stage {
 public:
  /// The stage of `model` (realised in prepare()); a ConfigError if it has more than kMaxStageStates.
  explicit LinearStage(models::LinearModel model) : model_(std::move(model)) {
    const Eigen::Index states = linear_stage_states(model_.tf);
    if (states > kMaxStageStates) {
      throw models::ConfigError("params: " + std::to_string(states) + " states (max(na, nb + nk)) are more than " +
                                "the engine runs (" + std::to_string(kMaxStageStates) + ")");
    }
  }
  /// Realises the model; throws if its fs differs from spec.fs (resampling is not the stage's job).
  void prepare(const ProcessSpec& spec) override {
    model_stages_detail::require_rate(model_.fs, spec.fs, "linear stage");
    runner_ = models::StateSpaceRunner(models::realize(model_.tf));
  }
  /// y(k) = C·x(k) + D·u(k), x(k+1) = A·x(k) + B·u(k), in scaled units.
  double process(double x) noexcept override {
    const models::Scaling& s = model_.scaling;
    return runner_.step((x - s.u_offset) / s.u_scale) * s.y_scale + s.y_offset;
  }
  /// A block of process() (StateSpaceRunner::step_block: the state kept in registers).
  void process_block(std::span<const double> in, std::span<double> out) noexcept override {
    const models::Scaling& s = model_.scaling;
    for (std::size_t k = 0; k < in.size(); ++k) out[k] = (in[k] - s.u_offset) / s.u_scale;
    runner_.step_block(out, out);
    for (double& y : out.first(in.size())) y = y * s.y_scale + s.y_offset;
  }
  /// Ignores the plant.
  bool observes() const noexcept override { return false; }
  /// State to zero.
  void reset() noexcept override { runner_.reset(); }
  /// The model.
  const models::LinearModel& model() const { return model_; }

 private:
  models::LinearModel model_;
  models::StateSpaceRunner runner_;
};

/// A NARX model as a stage: raw input in, the model's raw output out.
class NarxStage : public Stage {
 public:
  /// The stage of `model`, its past outputs taken from `source`.
  explicit NarxStage(models::NarxModel model, FeedbackSource source = FeedbackSource::model)
      : model_(std::move(model)), source_(source) {}
  /// Sizes the regressor and the network's workspace; throws if the fs or the network shape is wrong.
  void prepare(const ProcessSpec& spec) override {
    model_stages_detail::require_rate(model_.fs, spec.fs, "NARX stage");
    const models::NarxStructure& st = model_.structure;
    if (model_.net.inputs() != st.inputs()) {
      throw std::invalid_argument("NARX stage: the structure has " + std::to_string(st.inputs()) +
                                  " network inputs (na + nb + 1), the network " + std::to_string(model_.net.inputs()));
    }
    network_ = models::MlpKernel(model_.net);
    history_ = models::NarxHistory(st);
  }
  /// [5G] y(k) = F(y(k−1..k−na), u(k−nk..k−nk−nb)) in scaled units.
  double process(double x) noexcept override {
    const models::Scaling& s = model_.scaling;
    history_.push_input((x - s.u_offset) / s.u_scale);
    const double y = network_.forward(history_.past_outputs(), history_.past_inputs());
    if (source_ == FeedbackSource::model) history_.push_output(y);
    return y * s.y_scale + s.y_offset;
  }
  /// In sensor mode, the measured output becomes the newest past output.
  void observe(double measured) noexcept override {
    if (source_ == FeedbackSource::sensor) {
      history_.push_output((measured - model_.scaling.y_offset) / model_.scaling.y_scale);
    }
  }
  /// In model mode, a block of process() without a call per sample (MlpKernel::free_run); in sensor mode,
  /// process() and observe(0) per sample are the chain's business (observes() is true).
  void process_block(std::span<const double> in, std::span<double> out) noexcept override {
    if (source_ == FeedbackSource::sensor) {
      Stage::process_block(in, out);
      return;
    }
    const models::Scaling& s = model_.scaling;
    for (std::size_t k = 0; k < in.size(); ++k) out[k] = (in[k] - s.u_offset) / s.u_scale;
    // [5G], its own output fed back (model mode)
    network_.free_run(history_, out.first(in.size()), out);
    for (double& y : out.first(in.size())) y = y * s.y_scale + s.y_offset;
  }
  /// True in sensor mode.
  bool observes() const noexcept override { return source_ == FeedbackSource::sensor; }
  /// Past inputs and outputs to zero.
  void reset() noexcept override { history_.reset(); }
  /// The model.
  const models::NarxModel& model() const { return model_; }

 private:
  models::NarxModel model_;
  FeedbackSource source_;
  models::MlpKernel network_;    // model_.net prepared for the per-sample path
  models::NarxHistory history_;  // scaled u(k..k−nk−nb) and y(k−1..k−na)
};

}  // namespace panelbass::engine

#include "engine/stage.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/butterworth.h"
#include "models/io/config_error.h"

namespace panelbass::engine {
namespace {

// A model identified at another rate would run at the wrong speed: say so instead.
void require_rate(double model_fs, double fs, const char* stage) {
  if (!(std::abs(model_fs - fs) <= 1e-9 * fs)) {
    throw std::invalid_argument(std::string(stage) + ": the model was identified at " + std::to_string(model_fs) +
                                " Hz, the chain runs at " + std::to_string(fs) + " Hz");
  }
}

}  // namespace

void Stage::process_block(std::span<const double> in, std::span<double> out) noexcept {
  for (std::size_t k = 0; k < in.size(); ++k) out[k] = process(in[k]);
}

double Stage::warm_up(std::span<const double> input, std::span<const double> measured) noexcept {
  reset();
  double y = 0.0;
  for (std::size_t k = 0; k < input.size(); ++k) {
    y = process(input[k]);
    observe(measured[k]);
  }
  return y;
}

BandPassStage::BandPassStage(BandPassDesign design) : design_(design) {}

void BandPassStage::prepare(const ProcessSpec& spec) {
  const double low = design_.low.value;
  const double high = design_.high.value;
  if (!(low >= 0.0 && low < high && high < spec.fs / 2.0)) {
    throw std::invalid_argument("band-pass: corners must satisfy 0 <= low < high < fs/2 = " +
                                std::to_string(spec.fs / 2.0) + " Hz, got low = " + std::to_string(low) +
                                " Hz, high = " + std::to_string(high) + " Hz");
  }
  filter_ = dsp::SosFilter(dsp::butterworth_band(design_.order, low, high, spec.fs));
}

Eigen::Index linear_stage_states(const models::TransferFunction& tf) {
  return std::max<Eigen::Index>(tf.a.size(), tf.b.size() + tf.nk);
}

LinearStage::LinearStage(models::LinearModel model) : model_(std::move(model)) {
  const Eigen::Index states = linear_stage_states(model_.tf);
  if (states > kMaxLinearStageStates) {
    throw models::ConfigError("params: " + std::to_string(states) + " states (max(na, nb + nk)) are more than " +
                              "the engine runs (" + std::to_string(kMaxLinearStageStates) + ")");
  }
}

void LinearStage::prepare(const ProcessSpec& spec) {
  require_rate(model_.fs, spec.fs, "linear stage");
  ss_ = models::realize(model_.tf);
  c_ = ss_.C.transpose();
  state_ = Eigen::VectorXd::Zero(ss_.order());
  next_ = Eigen::VectorXd::Zero(ss_.order());
}

double LinearStage::process(double x) noexcept {
  const models::Scaling& s = model_.scaling;
  const double u = (x - s.u_offset) / s.u_scale;
  // y(k) = C·x(k) + D·u(k),  x(k+1) = A·x(k) + B·u(k)  (the same steps as models::simulate)
  const double y = c_.dot(state_) + ss_.D * u;
  next_.noalias() = ss_.A * state_;
  next_ += ss_.B * u;
  state_.swap(next_);
  return y * s.y_scale + s.y_offset;
}

void LinearStage::reset() noexcept { state_.setZero(); }

NarxStage::NarxStage(models::NarxModel model, FeedbackSource source) : model_(std::move(model)), source_(source) {}

void NarxStage::prepare(const ProcessSpec& spec) {
  require_rate(model_.fs, spec.fs, "NARX stage");
  const models::NarxStructure& st = model_.structure;
  if (model_.net.inputs() != st.inputs()) {
    throw std::invalid_argument("NARX stage: the structure has " + std::to_string(st.inputs()) +
                                " network inputs (na + nb + 1), the network " + std::to_string(model_.net.inputs()));
  }
  workspace_ = model_.net.workspace();
  regressor_ = Eigen::VectorXd::Zero(st.inputs());
  past_u_.assign(static_cast<std::size_t>(st.nk + st.nb + 1), 0.0);
  past_y_.assign(static_cast<std::size_t>(st.na), 0.0);
}

double NarxStage::process(double x) noexcept {
  const models::NarxStructure& st = model_.structure;
  const models::Scaling& s = model_.scaling;
  std::copy_backward(past_u_.begin(), past_u_.end() - 1, past_u_.end());
  past_u_[0] = (x - s.u_offset) / s.u_scale;
  // [5G] regressor [y(k−1)..y(k−na), u(k−nk)..u(k−nk−nb)]
  for (int i = 0; i < st.na; ++i) regressor_[i] = past_y_[static_cast<std::size_t>(i)];
  for (int j = 0; j <= st.nb; ++j) regressor_[st.na + j] = past_u_[static_cast<std::size_t>(st.nk + j)];
  const double y = model_.net.forward(regressor_, workspace_);
  if (source_ == FeedbackSource::model) push_output(y);
  return y * s.y_scale + s.y_offset;
}

void NarxStage::observe(double measured) noexcept {
  if (source_ == FeedbackSource::sensor) push_output((measured - model_.scaling.y_offset) / model_.scaling.y_scale);
}

void NarxStage::push_output(double y_scaled) noexcept {
  if (past_y_.empty()) return;
  std::copy_backward(past_y_.begin(), past_y_.end() - 1, past_y_.end());
  past_y_[0] = y_scaled;
}

void NarxStage::reset() noexcept {
  std::fill(past_u_.begin(), past_u_.end(), 0.0);
  std::fill(past_y_.begin(), past_y_.end(), 0.0);
}

}  // namespace panelbass::engine

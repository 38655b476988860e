#include "engine/stage.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/butterworth.h"
#include "dsp/sample_rate.h"
#include "models/io/config_error.h"

namespace panelbass::engine {
namespace {

// A model identified at another rate would run at the wrong speed: say so instead.
void require_rate(double model_fs, double fs, const char* stage) {
  if (!dsp::same_rate(model_fs, fs)) {
    throw std::invalid_argument(std::string(stage) + ": the model was identified at " + std::to_string(model_fs) +
                                " Hz, the chain runs at " + std::to_string(fs) + " Hz");
  }
}

}  // namespace

void Stage::process_block(std::span<const double> in, std::span<double> out) noexcept {
  for (std::size_t k = 0; k < in.size(); ++k) out[k] = process(in[k]);
}

void PassThroughStage::process_block(std::span<const double> in, std::span<double> out) noexcept {
  if (out.data() != in.data()) std::copy(in.begin(), in.end(), out.begin());
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
  if (states > kMaxStageStates) {
    throw models::ConfigError("params: " + std::to_string(states) + " states (max(na, nb + nk)) are more than " +
                              "the engine runs (" + std::to_string(kMaxStageStates) + ")");
  }
}

void LinearStage::prepare(const ProcessSpec& spec) {
  require_rate(model_.fs, spec.fs, "linear stage");
  runner_ = models::StateSpaceRunner(models::realize(model_.tf));
}

double LinearStage::process(double x) noexcept {
  const models::Scaling& s = model_.scaling;
  const double u = (x - s.u_offset) / s.u_scale;
  return runner_.step(u) * s.y_scale + s.y_offset;
}

void LinearStage::process_block(std::span<const double> in, std::span<double> out) noexcept {
  const models::Scaling& s = model_.scaling;
  for (std::size_t k = 0; k < in.size(); ++k) out[k] = (in[k] - s.u_offset) / s.u_scale;
  runner_.step_block(out, out);
  for (double& y : out.first(in.size())) y = y * s.y_scale + s.y_offset;
}

void LinearStage::reset() noexcept { runner_.reset(); }

NarxStage::NarxStage(models::NarxModel model, FeedbackSource source) : model_(std::move(model)), source_(source) {}

void NarxStage::prepare(const ProcessSpec& spec) {
  require_rate(model_.fs, spec.fs, "NARX stage");
  const models::NarxStructure& st = model_.structure;
  if (model_.net.inputs() != st.inputs()) {
    throw std::invalid_argument("NARX stage: the structure has " + std::to_string(st.inputs()) +
                                " network inputs (na + nb + 1), the network " + std::to_string(model_.net.inputs()));
  }
  network_ = models::MlpKernel(model_.net);
  history_ = models::NarxHistory(st);
}

double NarxStage::process(double x) noexcept {
  const models::Scaling& s = model_.scaling;
  history_.push_input((x - s.u_offset) / s.u_scale);
  // [5G] y(k) = F(y(k−1..k−na), u(k−nk..k−nk−nb))
  const double y = network_.forward(history_.past_outputs(), history_.past_inputs());
  if (source_ == FeedbackSource::model) history_.push_output(y);
  return y * s.y_scale + s.y_offset;
}

void NarxStage::process_block(std::span<const double> in, std::span<double> out) noexcept {
  if (source_ == FeedbackSource::sensor) {
    Stage::process_block(in, out);
    return;
  }
  const models::Scaling& s = model_.scaling;
  for (std::size_t k = 0; k < in.size(); ++k) out[k] = (in[k] - s.u_offset) / s.u_scale;
  // [5G] y(k) = F(y(k−1..k−na), u(k−nk..k−nk−nb)), its own output fed back (model mode)
  network_.free_run(history_, out.first(in.size()), out);
  for (double& y : out.first(in.size())) y = y * s.y_scale + s.y_offset;
}

void NarxStage::observe(double measured) noexcept {
  if (source_ == FeedbackSource::sensor) {
    history_.push_output((measured - model_.scaling.y_offset) / model_.scaling.y_scale);
  }
}

void NarxStage::reset() noexcept { history_.reset(); }

}  // namespace panelbass::engine

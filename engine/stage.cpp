#include "engine/stage.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/butterworth.h"

namespace panelbass::engine {

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

}  // namespace panelbass::engine

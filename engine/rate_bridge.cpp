#include "engine/rate_bridge.h"

#include <samplerate.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace panelbass::engine {
namespace {

int converter_type(ResampleQuality quality) {
  switch (quality) {
    case ResampleQuality::fastest:
      return SRC_SINC_FASTEST;
    case ResampleQuality::medium:
      return SRC_SINC_MEDIUM_QUALITY;
    case ResampleQuality::best:
      return SRC_SINC_BEST_QUALITY;
    case ResampleQuality::low_latency:
      break;
  }
  return SRC_SINC_FASTEST;
}

double checked_ratio(Hertz from, Hertz to) {
  if (!(std::isfinite(from.value) && from.value > 0.0 && std::isfinite(to.value) && to.value > 0.0)) {
    throw std::invalid_argument("resampler: rates must be finite and > 0, got " + std::to_string(from.value) +
                                " Hz -> " + std::to_string(to.value) + " Hz");
  }
  const double ratio = to.value / from.value;
  if (!src_is_valid_ratio(ratio)) {
    throw std::invalid_argument("resampler: " + std::to_string(from.value) + " Hz -> " + std::to_string(to.value) +
                                " Hz is a ratio of " + std::to_string(ratio) + ", outside libsamplerate's [1/256, 256]");
  }
  return ratio;
}

}  // namespace

const char* resample_quality_name(ResampleQuality quality) {
  switch (quality) {
    case ResampleQuality::fastest:
      return "fastest";
    case ResampleQuality::medium:
      return "medium";
    case ResampleQuality::best:
      return "best";
    case ResampleQuality::low_latency:
      return "low-latency";
  }
  return "?";
}

StreamingResampler::StreamingResampler(Hertz from, Hertz to, int channels, int max_input, ResampleQuality quality)
    : ratio_(checked_ratio(from, to)), channels_(channels), max_input_(static_cast<std::size_t>(std::max(max_input, 0))) {
  if (channels < 1 || max_input < 1) {
    throw std::invalid_argument("resampler: channels and max_input must be >= 1, got " + std::to_string(channels) +
                                " and " + std::to_string(max_input));
  }
  // In steady state a call yields input · ratio frames give or take one; the slack covers a call that
  // completes frames held back from the one before.
  out_stride_ = static_cast<std::size_t>(std::ceil(static_cast<double>(max_input) * ratio_)) + 8;
  if (quality == ResampleQuality::low_latency) {
    polyphase_ = std::make_unique<dsp::PolyphaseResampler>(from.value, to.value, channels, max_input, kLowLatencySpec);
    out_stride_ = polyphase_->max_output();
    return;
  }
  int error = 0;
  state_ = src_new(converter_type(quality), channels, &error);
  if (state_ == nullptr) {
    throw std::invalid_argument(std::string("resampler: libsamplerate: ") + src_strerror(error));
  }
  const auto ch = static_cast<std::size_t>(channels);
  in_interleaved_.assign(max_input_ * ch, 0.0f);
  out_interleaved_.assign(out_stride_ * ch, 0.0f);
  out_.assign(out_stride_ * ch, 0.0);
}

StreamingResampler::~StreamingResampler() {
  if (state_ != nullptr) src_delete(static_cast<SRC_STATE*>(state_));
}

std::size_t StreamingResampler::process(std::span<const std::span<const double>> in) noexcept {
  produced_ = 0;
  const std::size_t ch = static_cast<std::size_t>(channels_);
  const std::size_t frames = in.empty() ? 0 : std::min(in[0].size(), max_input_);
  if (in.size() != ch) {
    ++errors_;
    return 0;
  }
  if (polyphase_) {
    produced_ = polyphase_->process(in);
    return produced_;
  }
  for (std::size_t c = 0; c < ch; ++c) {
    const std::span<const double> x = in[c];
    for (std::size_t k = 0; k < frames; ++k) in_interleaved_[k * ch + c] = static_cast<float>(x[k]);
  }
  SRC_DATA data{};
  data.data_in = in_interleaved_.data();
  data.input_frames = static_cast<long>(frames);
  data.data_out = out_interleaved_.data();
  data.output_frames = static_cast<long>(out_stride_);
  data.end_of_input = 0;
  data.src_ratio = ratio_;
  if (src_process(static_cast<SRC_STATE*>(state_), &data) != 0 || data.input_frames_used != data.input_frames) {
    ++errors_;
  }
  produced_ = static_cast<std::size_t>(data.output_frames_gen);
  for (std::size_t c = 0; c < ch; ++c) {
    double* y = out_.data() + c * out_stride_;
    for (std::size_t k = 0; k < produced_; ++k) y[k] = out_interleaved_[k * ch + c];
  }
  return produced_;
}

void StreamingResampler::reset() noexcept {
  if (polyphase_) polyphase_->reset();
  if (state_ != nullptr) src_reset(static_cast<SRC_STATE*>(state_));
  produced_ = 0;
}

namespace {

const RateBridgeOptions& checked(const RateBridgeOptions& options) {
  if (options.max_period.value < 1) {
    throw std::invalid_argument("rate bridge: max_period must be >= 1, got " + std::to_string(options.max_period.value));
  }
  if (options.input_channels < 1) {
    throw std::invalid_argument("rate bridge: input_channels must be >= 1, got " +
                                std::to_string(options.input_channels));
  }
  if (options.margin.value < 0) {
    throw std::invalid_argument("rate bridge: margin must be >= 0, got " + std::to_string(options.margin.value));
  }
  return options;
}

int max_model_input(const RateBridgeOptions& o) {
  return static_cast<int>(std::ceil(o.max_period.value * o.model_rate.value / o.device_rate.value)) + 8;
}

/// Device frames after which the rates' pattern repeats (integer rates), else a fixed stretch.
long rate_cycle(double device, double model) {
  const auto d = static_cast<long>(std::llround(device)), m = static_cast<long>(std::llround(model));
  if (d > 0 && m > 0 && std::abs(device - static_cast<double>(d)) < 1e-9 && std::abs(model - static_cast<double>(m)) < 1e-9) {
    return d / std::gcd(d, m);
  }
  return 4096;
}

}  // namespace

RateBridge::RateBridge(const RateBridgeOptions& options)
    : options_(checked(options)),
      decimator_(options.device_rate, options.model_rate, options.input_channels, options.max_period.value,
                 options.quality),
      interpolator_(options.model_rate, options.device_rate, 1, max_model_input(options), options.quality),
      model_inputs_(static_cast<std::size_t>(options.input_channels)),
      model_out_(decimator_.max_output(), 0.0) {
  // The latency, found by running silence through the converters frame by frame: after n device frames
  // in, the interpolator has produced I(n) aligned frames; the FIFO must hold n − I(n) frames of
  // priming for every n (a check at every frame covers periods of any size). The pattern settles once
  // the interpolator's look-ahead has filled and then repeats every rate cycle.
  const double r = options.device_rate.value / options.model_rate.value;  // device samples per model sample
  const std::vector<double> zeros(static_cast<std::size_t>(options.input_channels), 0.0);
  std::vector<std::span<const double>> one(zeros.size());
  for (std::size_t c = 0; c < zeros.size(); ++c) one[c] = {zeros.data() + c, 1};
  const std::vector<double> model_zeros(decimator_.max_output(), 0.0);
  const long cycle = rate_cycle(options.device_rate.value, options.model_rate.value);
  long n = 0, decimated = 0, interpolated = 0, first_output = -1, shortfall = 0;
  double decimator_lag = 0.0, interpolator_lag = 0.0;
  constexpr long kGiveUp = 10'000'000;
  while (n < kGiveUp && (first_output < 0 || n < 2 * first_output + 8 * cycle + options.max_period.value)) {
    const std::size_t m = decimator_.process(one);
    ++n;
    decimated += static_cast<long>(m);
    if (m > 0) {
      const std::span<const double> z(model_zeros.data(), m);
      interpolated += static_cast<long>(interpolator_.process(std::span<const std::span<const double>>(&z, 1)));
    }
    // Lags in device samples: the decimator's output covers device time r·decimated, the interpolator's
    // `interpolated` frames of the r·decimated it was given.
    decimator_lag = std::max(decimator_lag, static_cast<double>(n) - r * static_cast<double>(decimated));
    interpolator_lag = std::max(interpolator_lag, r * static_cast<double>(decimated) - static_cast<double>(interpolated));
    shortfall = std::max(shortfall, n - interpolated);
    if (first_output < 0 && interpolated > 0) first_output = n;
  }
  decimator_.reset();
  interpolator_.reset();
  if (first_output < 0) throw std::invalid_argument("rate bridge: the converters produced no output");
  // The low-latency converters hold nothing back (shortfall 0) but delay by their filters' centres of
  // mass; libsamplerate's are the other way round.
  const double fs = options.device_rate.value;
  latency_.fifo_samples = static_cast<int>(std::max(shortfall, 0L)) + options.margin.value;
  latency_.filter_samples = fs * (decimator_.filter_delay_s() + interpolator_.filter_delay_s());
  latency_.total_samples = static_cast<int>(std::lround(latency_.fifo_samples + latency_.filter_samples));
  latency_.total_ms = 1e3 * (latency_.fifo_samples + latency_.filter_samples) / fs;
  latency_.decimator_samples = decimator_lag + fs * decimator_.filter_delay_s();
  latency_.interpolator_samples = interpolator_lag + fs * interpolator_.filter_delay_s();
  const std::size_t capacity = static_cast<std::size_t>(latency_.fifo_samples) +
                               static_cast<std::size_t>(options.max_period.value) + interpolator_.max_output() + 16;
  fifo_.assign(capacity, 0.0);
  prime();
}

void RateBridge::prime() noexcept {
  std::fill(fifo_.begin(), fifo_.end(), 0.0);
  head_ = 0;
  count_ = static_cast<std::size_t>(latency_.fifo_samples);
  debt_ = 0;
}

void RateBridge::reset() noexcept {
  decimator_.reset();
  interpolator_.reset();
  prime();
}

std::size_t RateBridge::decimate(std::span<const std::span<const double>> period) noexcept {
  const std::size_t n = decimator_.process(period);
  for (std::size_t c = 0; c < model_inputs_.size(); ++c) model_inputs_[c] = decimator_.output(static_cast<int>(c));
  return n;
}

void RateBridge::push(double x) noexcept {
  if (debt_ > 0) {
    --debt_;  // this frame's slot already went out as silence
    return;
  }
  if (count_ == fifo_.size()) {
    ++overflow_frames_;
    return;
  }
  // A wrap by comparison, not %: no integer division per frame.
  std::size_t tail = head_ + count_;
  if (tail >= fifo_.size()) tail -= fifo_.size();
  fifo_[tail] = x;
  ++count_;
}

void RateBridge::interpolate(std::size_t n, std::span<double> out) noexcept {
  if (n > 0) {
    const std::span<const double> model(model_out_.data(), std::min(n, model_out_.size()));
    const std::size_t got = interpolator_.process(std::span<const std::span<const double>>(&model, 1));
    for (const double x : interpolator_.output(0).first(got)) push(x);
  }
  for (double& y : out) {
    if (count_ == 0) {
      // Dry: silence now, and the frame that should have been here is dropped when it arrives, so the
      // delay stays latency().total_samples.
      y = 0.0;
      ++debt_;
      ++underrun_frames_;
      continue;
    }
    y = fifo_[head_];
    if (++head_ == fifo_.size()) head_ = 0;
    --count_;
  }
}

}  // namespace panelbass::engine

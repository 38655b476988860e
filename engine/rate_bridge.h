#pragma once
// Multirate operation on the real-time path: a sound card at 44.1/48 kHz, a chain at the models' rate
// (the thesis's 3000 Hz). Device frames are decimated to the model rate, the chain runs there, and its
// drive is interpolated back, period by period, allocation-free after construction.
//
// The default converters (ResampleQuality::low_latency) are minimum-phase polyphase FIR filters
// (dsp/polyphase_resampler.h): no hold-back, and a filter delay of about 0.75 ms each way, so the
// bridge adds about 1.55 ms at low frequencies (80 dB alias rejection, ±0.002 dB ripple up to 1200 Hz;
// the group delay rises towards the band edge, see docs/engine.md).
// The others are libsamplerate's band-limited sinc converters at a fixed ratio. They are
// time-aligned (sample m of a converted stream sits exactly at time m / rate, no phase delay) but hold
// back output until the filter's look-ahead has arrived, and a period that is not a multiple of the
// ratio (44100 / 3000 = 14.7) yields a varying number of model samples. A FIFO on the device side,
// primed with silence, makes every period get exactly its frames; the priming plus the converters'
// own filter delay (none for libsamplerate's) is the bridge's whole latency: an impulse's centre of
// mass comes out latency().total_ms later.
//
// src_process() does not allocate: libsamplerate sizes its state (the sinc filter's buffer) in
// src_new(); the conversion loop only copies into it (src/src_sinc.c).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "dsp/polyphase_resampler.h"
#include "engine/stage.h"

namespace panelbass::engine {

/// Which converters: the low-latency polyphase filters, or one of libsamplerate's sinc converters
/// (its own quality figures).
enum class ResampleQuality {
  low_latency,  ///< minimum-phase polyphase FIR (dsp/polyphase_resampler.h): 80 dB, 80 % bandwidth, ~0.75 ms each way
  fastest,  ///< SRC_SINC_FASTEST: 97 dB SNR, 80 % bandwidth (1200 Hz at 3000 Hz: the band-pass's edge)
  medium,   ///< SRC_SINC_MEDIUM_QUALITY: 121 dB SNR, 90 % bandwidth; longer filter, more latency
  best,     ///< SRC_SINC_BEST_QUALITY: 144 dB SNR, 96 % bandwidth; longest filter, most latency
};

/// A short name of `quality` ("low-latency", "fastest", "medium", "best").
const char* resample_quality_name(ResampleQuality quality);

/// The filter specification of ResampleQuality::low_latency.
inline constexpr dsp::LowLatencySpec kLowLatencySpec{0.8, 80.0};

/// A streaming converter at a fixed ratio: `channels` channels at once (they share the timing), any
/// number of frames per call up to `max_input`. Construct on a control thread; process() is
/// allocation-free.
class StreamingResampler {
 public:
  /// A converter from `from` to `to` Hz; throws std::invalid_argument for a rate that is not finite
  /// and > 0, a ratio outside libsamplerate's [1/256, 256], channels < 1 or max_input < 1, and for
  /// low_latency a rate that is not a whole number of Hz or a ratio beyond 1000/1000 in lowest terms.
  StreamingResampler(Hertz from, Hertz to, int channels, int max_input, ResampleQuality quality);
  /// Frees libsamplerate's state.
  ~StreamingResampler();
  StreamingResampler(const StreamingResampler&) = delete;
  StreamingResampler& operator=(const StreamingResampler&) = delete;

  /// Converts the next frames: `in[c]` is channel c (all as long, at most max_input); returns how many
  /// output frames became available, each channel readable through output(c) until the next call.
  std::size_t process(std::span<const std::span<const double>> in) noexcept;
  /// Channel `channel` of what the last process() produced.
  std::span<const double> output(int channel) const noexcept {
    if (polyphase_) return polyphase_->output(channel);
    return {out_.data() + static_cast<std::size_t>(channel) * out_stride_, produced_};
  }
  /// Back to rest (silence before the next input), as if just constructed.
  void reset() noexcept;

  /// Output rate / input rate.
  double ratio() const { return ratio_; }
  /// Channels converted together.
  int channels() const { return channels_; }
  /// The most frames one process() call may produce.
  std::size_t max_output() const { return out_stride_; }
  /// Calls that libsamplerate refused or that could not place all their output (none expected).
  std::uint64_t errors() const { return errors_; }
  /// The converter's own delay at low frequencies, seconds: the low-latency filter's centre of mass;
  /// 0 for libsamplerate's time-aligned converters (their delay is the output they hold back).
  double filter_delay_s() const { return polyphase_ ? polyphase_->filter().delay_s : 0.0; }
  /// The low-latency converter's filter and figures; null for libsamplerate's.
  const dsp::LowLatencyFilter* low_latency_filter() const { return polyphase_ ? &polyphase_->filter() : nullptr; }

 private:
  std::unique_ptr<dsp::PolyphaseResampler> polyphase_;  // set for ResampleQuality::low_latency
  void* state_ = nullptr;  // SRC_STATE*, kept out of the header
  double ratio_;
  int channels_;
  std::size_t max_input_;
  std::size_t out_stride_;
  std::vector<float> in_interleaved_, out_interleaved_;
  std::vector<double> out_;
  std::size_t produced_ = 0;
  std::uint64_t errors_ = 0;
};

/// What a rate bridge converts between.
struct RateBridgeOptions {
  Hertz device_rate{48000.0};  ///< the sound card's rate
  Hertz model_rate{3000.0};    ///< the chain's rate (the models' fs)
  Samples max_period{1024};    ///< the longest device period process() is given
  int input_channels = 1;      ///< device channels decimated together (program input, sensor)
  ResampleQuality quality = ResampleQuality::low_latency;  ///< both converters' kind
  Samples margin{2};           ///< FIFO priming beyond the worst shortfall found (rounding drift)
};

/// The latency a bridge adds, device side.
struct RateBridgeLatency {
  double decimator_samples = 0.0;     ///< most device samples the decimator's output lags its input (hold-back + filter delay)
  double interpolator_samples = 0.0;  ///< most device samples the interpolator's output lags its input (hold-back + filter delay)
  int total_samples = 0;              ///< device in → device out delay at low frequencies, rounded to a sample
  double total_ms = 0.0;              ///< the same delay, unrounded, ms: fifo_samples + filter_samples at the device rate
  int fifo_samples = 0;               ///< the FIFO's priming (for libsamplerate's converters, the whole delay)
  double filter_samples = 0.0;        ///< both converters' own filter delay (centre of mass), device samples
};

/// Device rate → model rate → device rate, one device period at a time, with the FIFO that gives every
/// period exactly its frames. Construct on a control thread; the rest is for the audio thread.
class RateBridge {
 public:
  /// Two converters and a primed FIFO; measures the latency by running silence through the converters
  /// frame by frame (then resets them). Throws std::invalid_argument naming a bad option.
  explicit RateBridge(const RateBridgeOptions& options);

  /// One device period: decimates `period` (input_channels spans, all of length out.size() ≤
  /// max_period), calls `model(inputs, output)` with the model-rate samples that became available
  /// (input_channels spans and an output span as long; not called when there are none) and writes
  /// exactly out.size() device frames of the interpolated output into `out`.
  template <class Model>
  void process(std::span<const std::span<const double>> period, std::span<double> out, Model&& model) noexcept {
    const std::size_t n = decimate(period);
    if (n > 0) model(std::span<const std::span<const double>>(model_inputs_), std::span<double>(model_out_.data(), n));
    interpolate(n, out);
  }

  /// The first half of process(): decimates one period; returns the model samples now in model_input().
  std::size_t decimate(std::span<const std::span<const double>> period) noexcept;
  /// Channel `channel` of the model-rate samples the last decimate() produced.
  std::span<const double> model_input(int channel) const noexcept { return model_inputs_[channel]; }
  /// Where the model writes its `n` output samples (n ≤ max_model_block()) before interpolate().
  std::span<double> model_output(std::size_t n) noexcept { return {model_out_.data(), n}; }
  /// The second half of process(): interpolates the first `n` samples of model_output() into the FIFO
  /// and takes out.size() device frames from it.
  void interpolate(std::size_t n, std::span<double> out) noexcept;
  /// Back to rest: converters cleared, FIFO primed again (after an xrun or a reopened device).
  void reset() noexcept;

  /// The latency the bridge adds.
  const RateBridgeLatency& latency() const { return latency_; }
  /// The most model samples one period can yield (a chain behind the bridge needs max_block ≥ this).
  std::size_t max_model_block() const { return decimator_.max_output(); }
  /// The options the bridge was built with.
  const RateBridgeOptions& options() const { return options_; }
  /// Device frames that had to be filled with silence because the FIFO ran dry (none expected).
  std::uint64_t underrun_frames() const { return underrun_frames_; }
  /// Device frames dropped because the FIFO was full (none expected).
  std::uint64_t overflow_frames() const { return overflow_frames_; }
  /// Converter calls that failed (none expected).
  std::uint64_t converter_errors() const { return decimator_.errors() + interpolator_.errors(); }

 private:
  void prime() noexcept;
  void push(double x) noexcept;

  RateBridgeOptions options_;
  StreamingResampler decimator_, interpolator_;
  RateBridgeLatency latency_;
  std::vector<std::span<const double>> model_inputs_;
  std::vector<double> model_out_;
  // The device-side FIFO: a ring of `fifo_.size()` frames.
  std::vector<double> fifo_;
  std::size_t head_ = 0, count_ = 0;
  std::size_t debt_ = 0;  // frames filled with silence that the next arrivals replace (keeps the delay)
  std::uint64_t underrun_frames_ = 0, overflow_frames_ = 0;
};

}  // namespace panelbass::engine

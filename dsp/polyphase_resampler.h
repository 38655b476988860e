#pragma once
// A low-latency rational resampler: a minimum-phase FIR low-pass run as a polyphase filter bank, for
// a sound card at 44.1/48 kHz on one side and the models' 3000 Hz on the other.
//
// Why not a library's converter: libsamplerate's sinc converters are linear-phase and hold output
// back until half their filter has arrived (13 ms through decimator and interpolator at 48 kHz with
// its fastest converter), and libsoxr, even with its minimum-phase recipes, buffers about 2800 input
// frames before its first output when decimating 48 kHz to 3 kHz (measured with 0.1.3, any recipe and
// DFT size). Both are built for throughput. A causal polyphase FIR has no hold-back at all: output m
// is computed as soon as the input sample at or before its time has arrived, and its only delay is
// the filter's own, which a minimum-phase filter keeps to a fraction of a millisecond.
//
// The prototype: a Kaiser-windowed sinc at the rate L·from (L/M = to/from in lowest terms), pass band
// up to `passband` of the lower Nyquist, stop band from (2 − passband) of it (the first frequency that
// folds — or images — into the pass band), made minimum-phase by the real cepstrum (same magnitude,
// so the same ripple and rejection; Oppenheim & Schafer, "Discrete-Time Signal Processing", §13.5).

#include <cstdint>
#include <span>
#include <vector>

namespace panelbass::dsp {

/// The specification of a low-latency converter's filter.
struct LowLatencySpec {
  double passband = 0.8;          ///< pass-band edge as a fraction of the lower Nyquist (0.8: 1200 Hz at 3000 Hz)
  double attenuation_db = 80.0;   ///< stop-band rejection, dB (the pass band then ripples by ±2·10^(−A/20))
};

/// The designed filter of a converter from `from` to `to` Hz, with the figures it meets.
struct LowLatencyFilter {
  int up = 1, down = 1;             ///< L and M: to/from = L/M in lowest terms
  double prototype_rate = 0.0;      ///< L·from, the rate the taps are sampled at (Hz)
  std::vector<double> taps;         ///< the minimum-phase prototype, DC gain 1, length a multiple of L
  double pass_hz = 0.0, stop_hz = 0.0;  ///< pass-band edge and stop-band start (Hz)
  double ripple_db = 0.0;           ///< the pass-band ripple bound, ± dB: 20·log10(1 + 2·10^(−attenuation/20)), 0.0017 dB at 80 dB
  double delay_s = 0.0;             ///< the delay at low frequencies: the taps' centre of mass, seconds
};

/// Designs the filter for `from` → `to` Hz (both whole numbers of Hz, L ≤ 1000 and M ≤ 1000). Throws
/// std::invalid_argument naming the bad rate, ratio or spec.
LowLatencyFilter design_low_latency_filter(double from, double to, const LowLatencySpec& spec);

/// The streaming converter: `channels` channels that share the timing, any number of frames per call.
/// Construction allocates; process() and reset() do not.
class PolyphaseResampler {
 public:
  /// A converter from `from` to `to` Hz (see design_low_latency_filter) for calls of at most `max_input`
  /// frames. Throws std::invalid_argument for a bad rate or spec, channels < 1 or max_input < 1.
  PolyphaseResampler(double from, double to, int channels, int max_input, const LowLatencySpec& spec);

  /// Converts the next frames (`in[c]` is channel c, all as long, at most max_input); returns how many
  /// output frames were produced, readable through output(c) until the next call. Output frame m is
  /// y(m/to) of the filtered input, emitted as soon as the input at or before that time has arrived.
  std::size_t process(std::span<const std::span<const double>> in) noexcept;
  /// Channel `channel` of the last process()'s output.
  std::span<const double> output(int channel) const noexcept {
    return {out_.data() + static_cast<std::size_t>(channel) * max_output_, produced_};
  }
  /// Back to rest: silence before the next input.
  void reset() noexcept;

  /// The filter and its figures.
  const LowLatencyFilter& filter() const { return filter_; }
  /// The most frames one process() call produces.
  std::size_t max_output() const { return max_output_; }

 private:
  LowLatencyFilter filter_;
  int channels_;
  std::size_t max_input_, max_output_, taps_per_phase_;
  std::vector<double> bank_;     // phase p's taps at [p·T, (p+1)·T), times L, newest input first
  std::vector<double> history_;  // per channel a doubled ring of 2T inputs (a contiguous window)
  std::vector<double> out_;
  std::size_t head_ = 0;         // where the next input goes in each ring
  std::int64_t inputs_ = 0;      // inputs consumed
  std::int64_t next_input_ = 0;  // floor(m·M / L) for the next output m: the input it waits for
  int next_phase_ = 0;           // (m·M) mod L for the next output m
  std::size_t produced_ = 0;
};

}  // namespace panelbass::dsp

#pragma once
// A measurement through the sound card: a drive at the chain's rate that the device thread plays instead
// of the chain's output, while it records the captured channels (sensor, current, loopback) at the same
// rate, sample for sample. The control thread builds it (every buffer sized here), hands it to the backend
// and waits; the device thread only copies samples and flips atomics (no allocation, lock or wait).
//
// The round-trip latency of the card (interpolator, playback buffer, converters, capture, decimator) is
// found afterwards by a calibration: the drive cross-correlated with the channel that hears it first — the
// drive looped back on a capture channel, or else the sensor (then the transducer's own delay is in it).

#include <Eigen/Core>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace panelbass::engine {

/// The channels a measurement records, at the chain's rate.
enum class MeasuredChannel : std::size_t { sensor = 0, current = 1, loopback = 2 };

/// One play-and-capture, shared by a control thread (builds, waits, reads) and the device thread (plays).
class Measurement {
 public:
  /// A measurement playing `drive` (chain rate, every sample within [−1, 1]); the program fades out over
  /// `fade_samples` before it and back in after it. Throws std::invalid_argument for a drive out of range,
  /// empty, or a fade < 1.
  Measurement(std::vector<double> drive, std::size_t fade_samples);

  /// Where the measurement is.
  enum class State : int {
    pending,    ///< handed over, not yet started by the device thread
    running,    ///< the device thread is playing it
    finished,   ///< played to its end: the captures are complete
    aborted,    ///< cancelled, or the device stopped or recovered an xrun during it
  };

  /// The state now (acquire: once finished, the captures are visible).
  State state() const noexcept { return state_.load(std::memory_order_acquire); }
  /// Asks the device thread to abandon it (it then ends as aborted).
  void cancel() noexcept { cancel_.store(true, std::memory_order_relaxed); }
  /// The drive played.
  const std::vector<double>& drive() const { return drive_; }
  /// Channel `c` as recorded (as long as the drive; zeros for a channel the card does not capture).
  const std::vector<double>& captured(MeasuredChannel c) const { return captured_[static_cast<std::size_t>(c)]; }
  /// The program's fade, samples at the chain's rate.
  std::size_t fade_samples() const { return fade_; }

  // The device thread's side (noexcept, allocation-free).
  /// Marks it running; false if it was cancelled before it started (it is then aborted).
  bool begin() noexcept;
  /// The next drive sample after recording `sensor`, `current`, `loopback` for the sample it answers;
  /// `done` turns true with the last one (the measurement is then finished).
  double step(double sensor, double current, double loopback, bool& done) noexcept;
  /// True when a cancel was asked for.
  bool cancelled() const noexcept { return cancel_.load(std::memory_order_relaxed); }
  /// Ends it as aborted (cancelled, an xrun, the device stopped).
  void abort() noexcept { state_.store(State::aborted, std::memory_order_release); }

 private:
  std::vector<double> drive_;
  std::array<std::vector<double>, 3> captured_;
  std::size_t fade_;
  std::size_t position_ = 0;
  std::atomic<State> state_{State::pending};
  std::atomic<bool> cancel_{false};
};

/// The card's round trip as a calibration found it.
struct RoundTrip {
  int samples = 0;          ///< whole samples at the chain's rate (the shift that aligns the record)
  double fractional = 0.0;  ///< the peak refined by a parabola through its neighbours, samples
  double peak = 0.0;        ///< the normalised cross-correlation at the peak (1: the drive came back unchanged)
};

/// How well the drive explains, sample by sample, a channel that hears it through a linear loop (the drive
/// looped back on a capture channel): a slip of the capture against the playback (a period dropped or
/// repeated inside the device's server, which no xrun counter sees) leaves a window the drive no longer
/// explains.
struct LoopConsistency {
  double worst_residual = 0.0;  ///< the largest Σ(heard − predicted)² / Σ heard² over a window
  Eigen::Index worst_at = 0;    ///< the first sample of that window
  bool slipped = false;         ///< worst_residual exceeded the tolerance
};

/// Fits an FIR (kLoopTaps taps, starting a few samples before `round_trip`) from `played` to `heard` over the
/// whole record, predicts `heard` with it and compares them window by window (kLoopWindow samples; windows
/// whose energy is below 1e-3 of the loudest window's are skipped). Throws std::invalid_argument for
/// unequal lengths, a round trip outside the record, or a record too short for the fit.
LoopConsistency check_loop(const Eigen::VectorXd& played, const Eigen::VectorXd& heard, int round_trip, double tolerance);

/// The FIR's length in check_loop, samples at the chain's rate (the card's converters ring well within it).
inline constexpr Eigen::Index kLoopTaps = 48;
/// The window check_loop compares over, samples (a JACK period is a few samples at the chain's rate).
inline constexpr Eigen::Index kLoopWindow = 256;
/// A loopback residual above this over a window is a slip or a gap (the JACK loop with no card leaves ~1e-12,
/// a card's converters' noise −60 dB or less; one sample of 256 lost or zeroed leaves ~4e-3, a shift of one
/// sample of broadband drive > 0.1).
inline constexpr double kLoopTolerance = 1e-4;

/// The lag in [0, max_lag] at which `heard` (same length as `played`) correlates best with `played`
/// (r(τ) = Σ u(k)·y(k+τ) / (N σ_u σ_y)); throws std::invalid_argument for unequal lengths, a
/// max_lag not below the length, or a silent signal.
RoundTrip find_round_trip(const Eigen::VectorXd& played, const Eigen::VectorXd& heard, Eigen::Index max_lag);

}  // namespace panelbass::engine

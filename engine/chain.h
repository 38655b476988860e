#pragma once
// The processing chain, run per block on the audio thread:
//   program input → band-pass → feedforward slot → feedback slot → safety limiter → drive.
// The feedback stage sees the measured plant output through observe() (sensor mode) or its own
// predictions (model mode). A non-finite value or a drive pinned at the rails drops the chain to
// band-pass only (the safe bypass) and raises a fault in the metrics until clear_fault().

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>

#include "engine/denormal_guard.h"
#include "engine/metrics.h"
#include "engine/model_slot.h"
#include "engine/safety_limiter.h"
#include "engine/stage.h"

namespace panelbass::engine {

/// Everything that shapes a chain.
struct ChainOptions {
  ProcessSpec spec{};            ///< rate (and longest block) the chain runs at
  BandPassDesign band_pass{};    ///< the band-pass stage the chain starts with
  SlotOptions slots{};           ///< crossfade and warm-up history of every slot
  LimiterOptions limiter{};      ///< the safety limiter
};

/// The chain's slots, in signal order.
enum class Position : std::size_t { band_pass = 0, feedforward = 1, feedback = 2 };

/// The per-block processing chain. Construct, set initial stages and install from the control thread;
/// process_block() from the audio thread.
class Chain {
 public:
  /// A chain with its band-pass stage prepared and active and empty (pass-through) model slots;
  /// throws std::invalid_argument for bad options.
  explicit Chain(const ChainOptions& options);
  Chain(const Chain&) = delete;
  Chain& operator=(const Chain&) = delete;

  /// The slot at `position`.
  ModelSlot& slot(Position position) { return *slots_[static_cast<std::size_t>(position)]; }
  /// The band-pass slot.
  ModelSlot& band_pass() { return slot(Position::band_pass); }
  /// The feedforward (linear controller) slot.
  ModelSlot& feedforward() { return slot(Position::feedforward); }
  /// The feedback (neural controller) slot.
  ModelSlot& feedback() { return slot(Position::feedback); }

  /// Control thread: new limiter settings, validated here (std::invalid_argument), taken by the audio
  /// thread at its next block boundary. Wait-free: a single pending copy behind an atomic flag; a second
  /// call before the audio thread took the first replaces it only once that one is taken (returns false
  /// then, nothing changed).
  bool set_limiter(const LimiterOptions& options);
  /// Control thread: a new crossfade length for every slot (from each slot's next block without a fade).
  void set_crossfade(Samples crossfade);
  /// Control thread: asks the audio thread to leave the safe bypass at its next block (stages reset).
  void clear_fault() { clear_request_.store(true, std::memory_order_release); }
  /// True while the chain is in its safe bypass.
  bool in_fault() const { return metrics_.in_fault(); }
  /// Control thread: frees the stages every slot has retired; returns how many.
  std::size_t collect_retired();
  /// The metrics (readable from any thread).
  const Metrics& metrics() const { return metrics_; }
  /// The metrics, for a backend to record xruns.
  Metrics& metrics() { return metrics_; }
  /// The options the chain was built with.
  const ChainOptions& options() const { return options_; }

  /// Audio thread: one block of program input into drive (same length); the plant is not observed (as the
  /// sensor overload below with a sensor that reads 0, and with the same numbers). With no swap, fade or
  /// fault under way it runs stage by stage over the block (block_run()), otherwise sample by sample.
  void process_block(std::span<const double> program, std::span<double> drive) noexcept;

  /// Audio thread: one block, sample by sample in a loop with the plant: `sensor(drive)` returns the
  /// measured output for that drive sample, which the stages observe before the next sample.
  template <class Sensor>
  void process_block(std::span<const double> program, std::span<double> drive, Sensor&& sensor) noexcept {
    const ScopedFlushDenormals no_denormals;  // decaying tails stay out of slow subnormal arithmetic
    const auto started = std::chrono::steady_clock::now();
    begin_block();
    for (std::size_t k = 0; k < program.size(); ++k) {
      drive[k] = process_sample(program[k]);
      observe(sensor(drive[k]));
    }
    end_block(drive, started);
  }

 private:
  void begin_block() noexcept;
  void end_block(std::span<const double> drive, std::chrono::steady_clock::time_point started) noexcept;
  double process_sample(double x) noexcept;
  double limit_sample(double band, double v) noexcept;
  bool block_runs() const noexcept;
  std::size_t block_run(std::span<const double> program, std::span<double> drive) noexcept;
  void observe(double measured) noexcept;
  void enter_safe_bypass(Fault fault) noexcept;

  ChainOptions options_;
  Metrics metrics_;
  std::unique_ptr<ModelSlot> slots_[kSlotCount];
  SafetyLimiter limiter_;
  std::atomic<bool> clear_request_{false};
  LimiterOptions pending_limiter_{};           // written by the control thread while the flag is false
  std::atomic<bool> limiter_request_{false};  // true: pending_limiter_ waits for the audio thread
  bool safe_bypass_ = false;  // audio thread only
  // An input so large that the band-pass might overflow has been seen: from then on every block runs
  // sample by sample, where such an overflow is caught at the sample it happens (audio thread only).
  bool huge_input_seen_ = false;
  // The limiter's work in the current block (audio thread only; reset by begin_block).
  struct BlockLimiting {
    std::uint64_t limited = 0;     // |v| above the knee: the limiter changed the drive
    std::uint64_t over_range = 0;  // |v| ≥ 1: the chain asked for more than full scale
    double peak_demand = 0.0;      // largest finite |v|
  } block_limiting_;
};

}  // namespace panelbass::engine

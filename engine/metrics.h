#pragma once
// Engine metrics: written by the audio thread with relaxed atomic stores (no locks, no allocation),
// read from any thread as a snapshot.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

namespace panelbass::engine {

/// Why the chain dropped to its safe bypass.
enum class Fault : std::uint8_t {
  none,               ///< no fault
  non_finite_input,   ///< the program input was NaN or infinite
  non_finite_output,  ///< a stage produced NaN or infinity
  pinned,             ///< the drive stayed at the rails longer than allowed
  sensor_lost,        ///< the sensor went silent: the feedback stage runs on its plant model (no bypass)
};

/// A short name of `fault` ("none", "non-finite input", …).
const char* fault_name(Fault fault);

/// Number of model slots in a chain (band-pass, feedforward, feedback).
inline constexpr std::size_t kSlotCount = 3;

/// The metrics at one moment.
struct MetricsSnapshot {
  std::uint64_t blocks = 0;      ///< blocks processed
  std::uint64_t samples = 0;     ///< samples processed
  std::uint64_t faults = 0;      ///< times the chain dropped to its safe bypass
  std::uint64_t swaps = 0;       ///< stages taken over from a pending install
  std::uint64_t xruns = 0;       ///< blocks that missed their deadline (backends report them)
  double mean_block_ns = 0.0;    ///< mean processing time of a block
  double p50_block_ns = 0.0;     ///< median (upper edge of its histogram bin, ≤ max)
  double p99_block_ns = 0.0;     ///< 99th percentile (upper edge of its histogram bin, ≤ max)
  double max_block_ns = 0.0;     ///< longest block
  double ns_per_sample = 0.0;    ///< processing time per sample
  double load = 0.0;             ///< processing time / audio time (1 = no headroom left)
  double peak_drive = 0.0;       ///< largest |drive| sent so far (the limiter keeps it ≤ 1)
  double max_late_ns = 0.0;      ///< most a paced block was behind its schedule (beyond the buffer: an xrun)
  std::uint64_t limited_samples = 0;     ///< samples the limiter changed (|drive asked for| above its knee)
  std::uint64_t over_range_samples = 0;  ///< samples whose drive asked for was at or beyond full scale (|v| ≥ 1)
  double peak_demand = 0.0;      ///< largest |drive asked for| before the limiter (may exceed 1)
  bool in_fault = false;         ///< the chain is in its safe bypass now
  Fault last_fault = Fault::none;  ///< the most recent fault
  std::array<std::uint64_t, kSlotCount> active_ids{};  ///< id of the stage active in each slot
};

/// Counters and a block-time histogram; record_*() from the audio thread only, snapshot() from anywhere.
class Metrics {
 public:
  /// Histogram bins: 8 exact ones below 8 ns, then 4 per octave up to 2^64 ns.
  static constexpr std::size_t kBins = 8 + 61 * 4;

  /// The sample rate that turns samples into audio time (before the audio thread starts).
  void set_rate(double fs) { fs_ = fs; }

  /// One block of `samples` took `ns` nanoseconds.
  void record_block(std::uint64_t ns, std::size_t samples) noexcept;
  /// The chain dropped to its safe bypass because of `fault`.
  void record_fault(Fault fault) noexcept;
  /// The chain is (true) or is no longer (false) in its safe bypass.
  void set_in_fault(bool in_fault) noexcept { in_fault_.store(in_fault, std::memory_order_relaxed); }
  /// A slot took over a pending stage.
  void record_swap() noexcept { swaps_.fetch_add(1, std::memory_order_relaxed); }
  /// The stage now active in `slot` has id `id`.
  void set_active_id(std::size_t slot, std::uint64_t id) noexcept;
  /// The largest |drive| of a block.
  void record_peak_drive(double peak) noexcept {
    if (peak > peak_drive_.load(std::memory_order_relaxed)) peak_drive_.store(peak, std::memory_order_relaxed);
  }
  /// One block's limiter activity: `limited` samples compressed above the knee, `over_range` of them asked
  /// for full scale or more, `peak_demand` the largest |drive asked for|.
  void record_limiting(std::uint64_t limited, std::uint64_t over_range, double peak_demand) noexcept {
    if (limited > 0) limited_samples_.fetch_add(limited, std::memory_order_relaxed);
    if (over_range > 0) over_range_samples_.fetch_add(over_range, std::memory_order_relaxed);
    if (peak_demand > peak_demand_.load(std::memory_order_relaxed)) {
      peak_demand_.store(peak_demand, std::memory_order_relaxed);
    }
  }
  /// A block missed its deadline.
  void record_xrun() noexcept { xruns_.fetch_add(1, std::memory_order_relaxed); }
  /// A paced block ended `ns` after its place in the schedule (0 when on time); the largest is kept. It
  /// tells an xrun from slow processing (max_block_ns) apart from one from a late wake-up.
  void record_lateness(std::uint64_t ns) noexcept {
    if (ns > max_late_ns_.load(std::memory_order_relaxed)) max_late_ns_.store(ns, std::memory_order_relaxed);
  }

  /// True while the chain is in its safe bypass (cheaper than a snapshot).
  bool in_fault() const noexcept { return in_fault_.load(std::memory_order_relaxed); }
  /// Stages taken over so far (cheaper than a snapshot).
  std::uint64_t swaps() const noexcept { return swaps_.load(std::memory_order_relaxed); }
  /// Xruns so far (cheaper than a snapshot).
  std::uint64_t xruns() const noexcept { return xruns_.load(std::memory_order_relaxed); }

  /// A consistent-enough copy of every figure (each counter read atomically).
  MetricsSnapshot snapshot() const;

  /// The histogram bin of a block time.
  static std::size_t bin_of(std::uint64_t ns) noexcept;
  /// The exclusive upper edge of bin `bin`, ns.
  static double bin_upper_ns(std::size_t bin) noexcept;

 private:
  static_assert(std::atomic<std::uint64_t>::is_always_lock_free);

  double fs_ = 0.0;
  std::atomic<std::uint64_t> blocks_{0}, samples_{0}, total_ns_{0}, max_ns_{0};
  std::atomic<std::uint64_t> faults_{0}, swaps_{0}, xruns_{0}, max_late_ns_{0};
  std::atomic<bool> in_fault_{false};
  std::atomic<double> peak_drive_{0.0};
  std::atomic<std::uint64_t> limited_samples_{0}, over_range_samples_{0};
  std::atomic<double> peak_demand_{0.0};
  static_assert(std::atomic<double>::is_always_lock_free);
  std::atomic<Fault> last_fault_{Fault::none};
  std::array<std::atomic<std::uint64_t>, kSlotCount> active_ids_{};
  std::array<std::atomic<std::uint64_t>, kBins> histogram_{};
};

}  // namespace panelbass::engine

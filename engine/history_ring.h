#pragma once
// A model slot's recent history: the inputs it processed and the plant outputs it observed, written by
// the audio thread and copied by the control thread without a lock, so a new stage can be warmed off the
// audio thread. A sequence counter (as in a seqlock) tells the reader which of the samples it copied the
// writer may have overwritten meanwhile; those are dropped, never waited for.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace panelbass::engine {

/// The last `length` samples of a slot's input and measured output, sample k at position k mod length.
class HistoryRing {
 public:
  /// A copy of consecutive samples [end − input.size(), end), oldest first.
  struct Snapshot {
    std::vector<double> input;     ///< the inputs
    std::vector<double> measured;  ///< the measured outputs (0 where none was observed)
    std::uint64_t end = 0;         ///< one past the last sample copied
  };

  /// Room for `length` samples (0: no history is kept, only the count).
  explicit HistoryRing(std::size_t length);
  HistoryRing(const HistoryRing&) = delete;
  HistoryRing& operator=(const HistoryRing&) = delete;

  /// Samples it keeps at most.
  std::size_t length() const noexcept { return input_.size(); }

  // ---- audio thread ----

  /// Sample count() begins: input `x`, measured output 0 until set_measured(); the sample before is final.
  void push_input(double x) noexcept;
  /// The measured output of the newest sample, which is final from now on.
  void set_measured(double y) noexcept;
  /// A run of samples at once, each as push_input() with measured output 0; the first `observed` of them
  /// become final as set_measured(0) would make them (all of them, or all but the last when the chain
  /// stopped observing this slot at its last sample).
  void push_block(std::span<const double> in, std::size_t observed) noexcept;
  /// Samples pushed so far.
  std::uint64_t count() const noexcept { return count_; }
  /// The input of sample k, count() − length() ≤ k < count().
  double input(std::uint64_t k) const noexcept { return input_[k % input_.size()].load(std::memory_order_relaxed); }
  /// The measured output of sample k, count() − length() ≤ k < count().
  double measured(std::uint64_t k) const noexcept {
    return measured_[k % measured_.size()].load(std::memory_order_relaxed);
  }

  // ---- any thread ----

  /// Copies the newest final samples, at most `n`, into `out` (resized; allocates), dropping any that the
  /// audio thread overwrote while they were copied.
  void snapshot(std::size_t n, Snapshot& out) const;

 private:
  std::vector<std::atomic<double>> input_, measured_;
  std::atomic<std::uint64_t> final_{0};    // samples before this one are final
  std::atomic<std::uint64_t> touched_{0};  // samples from this one − length() on have not been overwritten
  std::uint64_t count_ = 0;                // the audio thread's own count
  std::size_t newest_ = 0;                 // (count_ − 1) mod length: where the newest sample is
  std::size_t next_ = 0;                   // count_ mod length: where the next one goes
};

}  // namespace panelbass::engine

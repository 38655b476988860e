#pragma once
// A model slot: the stage active at one position of the chain, replaced while audio runs without a
// click and without the audio thread ever locking, allocating or freeing (JUCE's Convolution hand-over:
// the new engine is built off the audio thread, taken over at a block boundary, crossfaded, and the old
// one is deleted off the audio thread).
//
// Threads: one control thread calls install(), collect_retired() and set_bypassed(); the audio thread
// calls begin_block(), process(), observe() and reset(). Hand-over: the control thread prepares a stage,
// warms it from a snapshot of the slot's recent history (HistoryRing) and publishes it with an atomic
// exchange; the audio thread takes it with another at a block boundary, runs it over the few samples that
// came after the snapshot, crossfades to it, and pushes the retired stage onto a lock-free
// single-producer single-consumer queue that the control thread drains and frees. The catch-up is at
// most a block's samples in the block the crossfade begins; a stage further behind (it waited, e.g.
// behind another crossfade) catches up over several blocks first, a block and a quarter per block, so no
// block pays for a whole warm-up.
//
// The crossfade is step-bounded: its gain rises by 1/crossfade per sample unless that would make the
// output step further than the larger of the two stages' own steps at that sample and the output's
// recent peak step; then it rises only as far as that bound allows (but at least 1/(4·crossfade) per
// sample, so a fade always ends). A swap thus adds no step larger than the signals already have.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "engine/history_ring.h"
#include "engine/metrics.h"
#include "engine/spsc_queue.h"
#include "engine/stage.h"

namespace panelbass::engine {

/// How a slot hands stages over.
struct SlotOptions {
  Samples crossfade{64};  ///< length of the crossfade to a new stage, and of a bypass ramp (0 = switch)
  Samples history{512};   ///< recent samples a new stage is warmed from
};

/// The stage at one chain position; an empty slot passes its input through.
class ModelSlot {
 public:
  /// An empty slot whose stages are prepared for `spec`; reports swaps to `metrics` as slot `index`.
  ModelSlot(const ProcessSpec& spec, const SlotOptions& options, Metrics& metrics, std::size_t index);
  /// Frees every stage it holds; the audio thread must no longer use the slot.
  ~ModelSlot();
  ModelSlot(const ModelSlot&) = delete;
  ModelSlot& operator=(const ModelSlot&) = delete;

  // ---- control thread ----

  /// Prepares `stage`, warms it from the slot's recent history (here, off the audio thread) and publishes
  /// it; the audio thread takes it over at its next block boundary. A stage published earlier and not yet
  /// taken is freed here. Throws (nothing published) if prepare() throws or `stage` is null.
  void install(std::unique_ptr<Stage> stage);
  /// Prepares `stage` and makes it active at once, freeing the one before; only while no audio runs.
  void set_initial(std::unique_ptr<Stage> stage);
  /// Frees the stages the audio thread has retired; returns how many.
  std::size_t collect_retired();
  /// Bypass on (output = input) or off; the audio thread ramps over the crossfade length.
  void set_bypassed(bool bypassed) { bypass_request_.store(bypassed, std::memory_order_relaxed); }
  /// Control thread: a new crossfade length (≥ 0), taken by the audio thread at its next block.
  void set_crossfade(Samples crossfade);
  /// Bypass on or off at once, without a ramp; only while no audio runs (a chain starting bypassed).
  void set_initial_bypass(bool bypassed);
  /// True when bypass was requested.
  bool bypassed() const { return bypass_request_.load(std::memory_order_relaxed); }
  /// True when no stage waits to be taken over and no crossfade runs.
  bool idle() const;

  // ---- audio thread ----

  /// At a block boundary: takes over a pending stage (catching it up with the history since it was
  /// warmed) and reads the bypass request.
  void begin_block() noexcept;
  /// One sample through the slot (crossfading while a new stage takes over).
  double process(double x) noexcept;
  /// The measured plant output for the sample just processed: kept in the history, passed to the stages.
  void observe(double measured) noexcept;
  /// True when a whole block may run at once (process_block): no stage is being taken over or crossfaded,
  /// no bypass ramp runs, and the active stage ignores the plant's output (Stage::observes() is false).
  bool steady() const noexcept {
    return incoming_ == nullptr && wet_ == wet_target_ && (active_ == nullptr || !active_->stage->observes());
  }
  /// Only when steady(), at most the spec's max_block samples: the block through the slot with no plant
  /// observed, as process() then observe(0) per sample would run it; returns the output (valid until the
  /// next call). What the slot itself records (history, the step peak a later crossfade bounds its steps by)
  /// waits for commit_block(), so a chain cut short by a fault inside the block records only what counted.
  std::span<const double> process_block(std::span<const double> in) noexcept;
  /// After process_block(in): its first `processed` samples count as processed, the first `observed` of
  /// them as observed (`observed` = `processed`, or one less when the chain stopped observing the slot at
  /// its last sample).
  void commit_block(std::span<const double> in, std::size_t processed, std::size_t observed) noexcept;
  /// The stages back to rest (after a fault).
  void reset() noexcept;
  /// A fault the active (or incoming) stage raised since the last call (Stage::take_fault).
  Fault take_fault() noexcept;

 private:
  // A stage as the slot holds it: warmed over the history up to sample `warmed_through`.
  struct Entry {
    std::unique_ptr<Stage> stage;
    std::uint64_t warmed_through = 0;  // one past the last history sample it has run over
    double last_output = 0.0;          // its output for that sample
  };

  double next_fade_gain(double old_out, double new_out) const noexcept;
  bool catch_up(Entry& entry) noexcept;
  void finish_swap() noexcept;

  ProcessSpec spec_;
  SlotOptions options_;
  Metrics& metrics_;
  std::size_t index_;

  std::atomic<Entry*> pending_{nullptr};
  std::atomic<bool> bypass_request_{false};
  std::atomic<int> crossfade_request_{0};
  std::atomic<bool> fading_{false};  // a stage is being caught up or crossfaded to
  SpscQueue<Entry*, 16> retired_;

  // Owned by the audio thread while it runs.
  Entry* active_ = nullptr;
  Entry* warming_ = nullptr;  // taken from pending_, still catching up with the history
  Entry* incoming_ = nullptr;
  double fade_gain_ = 0.0;   // 0 = old stage, 1 = new stage
  double last_old_ = 0.0;    // previous output of the active stage
  double last_new_ = 0.0;    // previous output of the incoming stage
  double last_mix_ = 0.0;    // previous output of the crossfade (before the bypass mix)
  double step_peak_ = 0.0;   // recent peak of |output step|, decaying over the history length
  double peak_decay_ = 0.0;
  int crossfade_ = 0;        // the crossfade length in use (audio thread's copy of crossfade_request_)
  double wet_ = 1.0;         // 1 = stage output, 0 = bypassed
  double wet_target_ = 1.0;
  std::uint64_t block_samples_ = 0;  // samples processed since the last block boundary
  std::uint64_t block_peak_ = 0;     // the longest block so far
  std::vector<double> block_out_;    // process_block's stage outputs (max_block samples, sized once)
  std::vector<double> decay_powers_; // peak_decay_^i, i = 0..max_block (commit_block's step peak)
  std::span<const double> block_y_;  // the stage outputs of the last process_block (block_out_ or its input)
  HistoryRing history_;
};

}  // namespace panelbass::engine

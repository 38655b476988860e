#pragma once
// The program a live backend plays from memory, replaced while audio runs without a click and without the
// audio thread locking, allocating or freeing (the model slots' hand-over, engine/model_slot.h): the control
// thread builds the new program's buffer and publishes it with an atomic exchange; the audio thread takes
// it at a block boundary, fades the old program out and the new one in (raised cosine), and pushes the old
// buffer onto a lock-free single-producer single-consumer queue that the control thread drains and frees.

#include <atomic>
#include <cstddef>
#include <span>
#include <vector>

#include "engine/spsc_queue.h"

namespace panelbass::engine {

/// A looped (or played-once) program buffer, replaced with a fade; one control thread, one audio thread.
class ProgramPlayer {
 public:
  /// Plays `initial` from its start (empty: silence), looped or once; a replacement fades the old program
  /// out over `fade_samples` and the new one in over as many (0: switch at once).
  ProgramPlayer(std::vector<double> initial, bool loop, std::size_t fade_samples);
  /// Frees every buffer it holds; the audio thread must no longer use the player.
  ~ProgramPlayer();
  ProgramPlayer(const ProgramPlayer&) = delete;
  ProgramPlayer& operator=(const ProgramPlayer&) = delete;

  // ---- control thread ----

  /// Publishes `samples` (empty: silence) as the next program, played from its start once the audio thread
  /// has faded the current one out. A program published earlier and not yet taken is freed here.
  void install(std::vector<double> samples);
  /// Frees the programs the audio thread has retired; returns how many.
  std::size_t collect_retired();
  /// True when no program waits to be taken and no fade runs: what was installed last is what plays.
  bool idle() const {
    return pending_.load(std::memory_order_acquire) == nullptr && !fading_.load(std::memory_order_acquire);
  }
  /// The fade's length each way, samples.
  std::size_t fade_samples() const { return fade_; }

  // ---- audio thread ----

  /// The next `out.size()` samples of the program (a block boundary: a published program is taken here).
  /// Returns how many are program: fewer only when a program played once has ended (the rest are zeros).
  std::size_t fill(std::span<double> out) noexcept;

 private:
  using Buffer = std::vector<double>;

  double next_sample() noexcept;
  void take_pending() noexcept;

  bool loop_;
  std::size_t fade_;
  std::atomic<Buffer*> pending_{nullptr};
  std::atomic<bool> fading_{false};
  SpscQueue<Buffer*, 8> retired_;

  // Owned by the audio thread while it runs.
  Buffer* active_ = nullptr;
  Buffer* incoming_ = nullptr;  // taken, waiting for the active one's fade-out to end
  std::size_t position_ = 0;
  enum class Phase : unsigned char { playing, fading_out, fading_in };
  Phase phase_ = Phase::playing;
  std::size_t ramp_ = 0;
};

}  // namespace panelbass::engine

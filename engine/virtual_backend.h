#pragma once
// The embedded default backend: an audio thread runs the chain block by block into the virtual
// transducer in-process (sensor mode: the plant's measured output reaches the feedback stage sample by
// sample), paced like a sound card or as fast as the CPU allows.

#include <atomic>
#include <cstdint>
#include <functional>
#include <span>
#include <thread>
#include <vector>

#include "engine/chain.h"
#include "engine/program_player.h"
#include "models/plant/plant_config.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::engine {

/// How the audio thread is paced.
enum class Pacing {
  real_time,            ///< one block per block period; a late block counts as an xrun
  as_fast_as_possible,  ///< no waiting (tests, benchmarks)
};

/// One processed block, as the audio thread sees it.
struct BlockView {
  std::uint64_t index = 0;             ///< blocks before this one
  std::span<const double> program;     ///< the program input
  std::span<const double> drive;       ///< the chain's output
  std::span<const double> measured;    ///< the plant's measured output
};

/// What the virtual backend plays and simulates.
struct VirtualBackendOptions {
  Samples block{64};                   ///< block length (≤ the chain's max_block)
  Pacing pacing = Pacing::real_time;   ///< how the audio thread is paced
  /// Real time: periods of the sound card this stands for (ALSA's minimum is 2). A block may be late by
  /// up to buffer_periods − 1 periods, as a card's buffer allows, before it counts as an xrun.
  int buffer_periods = 2;
  std::vector<double> program;         ///< program input from its start (empty: silence)
  bool loop = true;                    ///< repeat the program; else the run ends when it has been played
  double program_fade_s = 0.025;       ///< a new program (program().install): the old faded out, the new in, each this long
  models::PlantConfig plant;           ///< the simulated transducer (its fs must be the chain's)
  std::uint64_t noise_seed = 1;        ///< the plant's sensor noise seed
  int realtime_priority = 0;           ///< SCHED_FIFO priority of the audio thread (0: normal scheduling)
  /// Called on the audio thread after each block; must not allocate, lock or wait.
  std::function<void(const BlockView&)> on_block;
};

/// The virtual-transducer backend; start() and stop() from a control thread.
class VirtualBackend {
 public:
  /// Validates `options` and sizes the buffers; throws std::invalid_argument naming the problem.
  VirtualBackend(Chain& chain, VirtualBackendOptions options);
  /// Stops the audio thread.
  ~VirtualBackend();
  VirtualBackend(const VirtualBackend&) = delete;
  VirtualBackend& operator=(const VirtualBackend&) = delete;

  /// Starts the audio thread (continuing where a previous run stopped); throws if it runs already.
  void start();
  /// Asks the audio thread to stop after its current block and joins it.
  void stop();
  /// Waits until a non-looping program has been played (returns at once if nothing runs).
  void wait();
  /// True once a non-looping program has been played to its end.
  bool finished() const { return finished_.load(std::memory_order_acquire); }
  /// Blocks processed so far.
  std::uint64_t blocks() const { return blocks_.load(std::memory_order_relaxed); }
  /// The audio thread got its SCHED_FIFO priority.
  bool realtime() const { return realtime_.load(std::memory_order_relaxed); }
  /// The process's memory got locked (asked for with the priority, once it was granted).
  bool memory_locked() const { return memory_locked_.load(std::memory_order_relaxed); }
  /// The program player: install() a new program from a control thread (faded in at the chain's rate),
  /// collect_retired() from housekeeping.
  ProgramPlayer& program() { return program_; }

 private:
  void run() noexcept;

  Chain& chain_;
  VirtualBackendOptions options_;
  models::VirtualTransducer plant_;
  ProgramPlayer program_;
  std::vector<double> program_block_, drive_, measured_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> finished_{false};
  std::atomic<std::uint64_t> blocks_{0};
  std::atomic<bool> realtime_{false};
  std::atomic<bool> memory_locked_{false};
};

}  // namespace panelbass::engine

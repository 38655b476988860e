#pragma once
// The ALSA backend: a device thread opens the playback and capture PCMs, then streams period by
// period: read the capture period (program input and sensor), decimate it to the chain's rate when the
// card runs at another (engine/rate_bridge.h), run the chain, interpolate the drive back and write it
// to the playback channel that feeds the amplifier.
//
// While streaming the thread neither allocates nor locks; it waits only on the devices (snd_pcm_wait
// with a timeout). An xrun is recovered with snd_pcm_recover, both streams are restarted in step, and
// the xrun is counted in the chain's metrics. A device that fails (unplugged, its JACK server gone,
// silent for longer than the timeout) is closed, reported in the status, and reopened with an
// exponential back-off until it comes back or stop() is called; the process stays up. Opening may
// allocate (libasound does); it happens on the same thread, between periods, never while one is processed.
//
// The backend's parts, a file pair each: sample formats (alsa_sample_format), the hardware and software
// parameters a PCM is opened with (alsa_hw_params), the device lifecycle — open, restart, close, reopen
// with back-off (alsa_devices) — and the stream loop, period by period (alsa_stream).

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "engine/chain.h"
#include "engine/measurement.h"
#include "engine/program_player.h"
#include "engine/rate_bridge.h"

namespace panelbass::engine {

/// A channel index that means "none".
inline constexpr int kNoChannel = -1;

/// One processed period, as the device thread sees it.
struct AlsaBlockView {
  std::uint64_t index = 0;               ///< periods processed since the backend was constructed
  std::span<const double> program;       ///< program input at the device rate
  std::span<const double> sensor;        ///< the sensor channel at the device rate (empty without one)
  std::span<const double> drive;         ///< the drive written to the playback channel, device rate
  std::span<const double> model_program; ///< program input at the chain's rate (this period's share)
  std::span<const double> model_drive;   ///< the chain's output at its rate (this period's share)
};

/// Everything that shapes the ALSA backend.
struct AlsaOptions {
  std::string playback_device = "default";  ///< PCM that feeds the amplifier ("" = no playback)
  std::string capture_device;               ///< PCM with program input and/or sensor ("" = no capture)
  Hertz rate{48000.0};                      ///< device rate; ≠ the chain's fs puts a rate bridge between
  Samples period{64};                       ///< period, frames
  int periods = 4;                          ///< periods in the device buffer (2..64)
  int playback_channels = 2;                ///< channels of the playback PCM
  int drive_channel = 0;                    ///< the playback channel carrying the drive (others silent)
  int capture_channels = 2;                 ///< channels of the capture PCM
  int program_channel = kNoChannel;         ///< capture channel with program input (none: `program`)
  int sensor_channel = kNoChannel;          ///< capture channel with the sensor (none: model mode)
  int current_channel = kNoChannel;         ///< capture channel with the coil current (measurements only)
  int loopback_channel = kNoChannel;        ///< capture channel hearing the drive itself (calibrates measurements)
  std::vector<double> program;              ///< program at the device rate when program_channel is none
  bool loop_program = true;                 ///< repeat `program`; else silence after its end
  double program_fade_s = 0.025;  ///< a new program (program().install): the old faded out, the new in, each this long
  std::string config_text;  ///< ALSA configuration to open both PCMs from (snd_pcm_open_lconf); "" = system's
  ResampleQuality quality = ResampleQuality::low_latency;  ///< the rate bridge's converters
  std::chrono::milliseconds reopen_min{50};    ///< first wait before reopening a lost device
  std::chrono::milliseconds reopen_max{2000};  ///< longest wait between reopen attempts (doubling)
  std::chrono::milliseconds device_timeout{0};  ///< no data for this long = device lost (0: 8 buffers, ≥ 200 ms)
  int realtime_priority = 0;  ///< SCHED_FIFO priority for the device thread (0: normal scheduling)
  /// Called on the device thread after each period; must not allocate, lock or wait.
  std::function<void(const AlsaBlockView&)> on_block;
};

/// Where the device thread is.
enum class AlsaState : std::uint8_t {
  stopped,    ///< no thread
  opening,    ///< opening and configuring the PCMs
  running,    ///< streaming
  reopening,  ///< the device failed or was lost; waiting out the back-off before the next attempt
};

/// A short name of `state` ("stopped", "opening", "running", "reopening").
const char* alsa_state_name(AlsaState state);

/// The backend's status at one moment.
struct AlsaStatus {
  AlsaState state = AlsaState::stopped;  ///< where the device thread is
  std::uint64_t opens = 0;               ///< successful opens (the first one included)
  std::uint64_t failed_opens = 0;        ///< open attempts that failed
  std::uint64_t losses = 0;              ///< times a running device was lost
  std::uint64_t xruns = 0;               ///< xruns recovered (also in the chain's metrics)
  std::uint64_t periods = 0;             ///< periods processed
  bool realtime = false;                 ///< the device thread got its SCHED_FIFO priority
  bool memory_locked = false;            ///< the process's memory got locked (asked for once realtime)
  std::array<char, 160> last_error{};    ///< the most recent error, NUL-terminated ("" if none)
  /// Successful opens after the first: how often a lost device came back.
  std::uint64_t reopens() const { return opens > 0 ? opens - 1 : 0; }
};

/// The ALSA backend; start() and stop() from a control thread, status() from any.
class AlsaBackend {
 public:
  /// Validates `options` against the chain and sizes every buffer (the rate bridge included when the
  /// device rate is not the chain's); throws std::invalid_argument naming the problem. Opens nothing.
  AlsaBackend(Chain& chain, AlsaOptions options);
  /// Stops the device thread.
  ~AlsaBackend();
  AlsaBackend(const AlsaBackend&) = delete;
  AlsaBackend& operator=(const AlsaBackend&) = delete;

  /// Starts the device thread, which opens the devices (retrying with back-off); throws if it runs.
  void start();
  /// Asks the device thread to stop (within one device timeout at most) and joins it; closes the PCMs.
  void stop();
  /// The status, lock-free (the error text through a sequence counter).
  AlsaStatus status() const;
  /// The rate bridge's latency (zeros when the device runs at the chain's rate).
  RateBridgeLatency resampling_latency() const;
  /// The options the backend was built with (`program` moved into the player).
  const AlsaOptions& options() const { return options_; }
  /// The program player (at the device rate; unused when program_channel is set): install() a new program
  /// from a control thread, collect_retired() from housekeeping.
  ProgramPlayer& program() { return player_; }
  /// Plays `m` on the device thread in place of the chain (the program faded out before it and back in
  /// after, the chain's stages not run meanwhile) and waits until it has finished or been aborted, at most
  /// `timeout` (then it is cancelled). Returns its final state; a measurement already under way (from
  /// another thread) makes this one wait its turn. Call from a control thread while the backend runs.
  Measurement::State measure(Measurement& m, std::chrono::milliseconds timeout);

 private:
  struct Devices;  // the PCMs, their configuration and raw buffers (libasound types stay in the .cpp)

  void run() noexcept;
  bool open_devices() noexcept;
  void close_devices() noexcept;
  bool stream() noexcept;
  bool restart_streams() noexcept;
  int read_period() noexcept;
  int write_period() noexcept;
  void process_period() noexcept;
  void run_model_block(std::span<const std::span<const double>> in, std::span<double> out) noexcept;
  void end_measurement(bool aborted) noexcept;
  bool recover(void* pcm, int err, const char* where) noexcept;
  void set_error(const char* where, int err) noexcept;
  void set_error_text(const char* text) noexcept;
  bool sleep_unless_stopped(std::chrono::milliseconds wait) noexcept;

  Chain& chain_;
  AlsaOptions options_;
  ProgramPlayer player_;
  std::unique_ptr<RateBridge> bridge_;
  std::unique_ptr<Devices> devices_;
  // Device-rate channels of one period.
  std::vector<double> program_, sensor_, drive_;
  std::vector<double> current_, loopback_, zeros_;
  // Measurements: handed over through `measurement_request_`, played by the device thread alone.
  std::atomic<Measurement*> measurement_request_{nullptr};
  std::mutex measuring_;  // one measurement at a time (control threads only)
  enum class MeasurePhase : std::uint8_t { idle, fading_out, measuring, fading_in };
  Measurement* measurement_ = nullptr;  // device thread only
  MeasurePhase phase_ = MeasurePhase::idle;
  std::size_t ramp_ = 0, fade_ = 1;
  std::uint64_t xruns_at_start_ = 0;
  std::uint64_t period_index_ = 0;

  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<AlsaState> state_{AlsaState::stopped};
  std::atomic<std::uint64_t> opens_{0}, failed_opens_{0}, losses_{0}, xruns_{0}, periods_{0};
  std::atomic<bool> realtime_{false}, memory_locked_{false};
  // The last error: a seqlock (odd = being written), the text in relaxed atomic chars.
  std::atomic<std::uint32_t> error_seq_{0};
  std::array<std::atomic<char>, 160> error_text_{};
};

}  // namespace panelbass::engine

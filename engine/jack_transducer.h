#pragma once
// The virtual transducer as a JACK client: drive in, sensor and coil current out, at the JACK server's
// rate, so the whole card path (ALSA's jack plugin, the dummy driver) runs without hardware. The plant is
// simulated at the server's rate (plant_at_rate): the same physics with the integrator's step, the
// converters' delay and the sensor noise's density kept, so nothing in the client resamples.
//
// The process callback runs VirtualTransducer::step per frame: noexcept and allocation-free. With a record
// window it also copies each frame's drive, sensor and noise-free acceleration into one of three preallocated
// windows, handed to a non-real-time reader (next_window) through lock-free queues of window indices, so the
// reader can judge the distortion from the transducer's side (cli/transducer_command.cpp's THD log). libjack
// (Debian libjack-jackd2-dev, LGPL) is linked dynamically.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "engine/spsc_queue.h"
#include "models/plant/plant_config.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::engine {

/// The same plant simulated at `rate` Hz instead of its fs: the integrator's step kept (oversample
/// scaled, at least 1), the converters' delay kept in time (rounded to whole samples at `rate`; a microphone's
/// delay exactly), and the white sensor noise per sample scaled by √(rate / fs) so its density (and its level
/// in the original band) is the same (the coloured noise's corners are in Hz: it keeps its level). Throws std::invalid_argument for a rate that is not finite and positive.
models::PlantConfig plant_at_rate(models::PlantConfig plant, double rate);

/// What a JACK transducer client is.
struct JackTransducerOptions {
  models::PlantConfig plant;                 ///< the plant (any fs: it is rescaled to the server's rate)
  std::string client_name = "panelbass-transducer";  ///< the client's name (its ports: <name>:drive, …)
  std::string server_name;                   ///< the JACK server ("" = the default, $JACK_DEFAULT_SERVER)
  std::uint64_t noise_seed = 1;              ///< the sensor noise's seed
  std::vector<std::string> drive_from;       ///< ports connected to our drive input once active
  std::vector<std::string> sensor_to;        ///< ports our sensor output is connected to once active
  std::vector<std::string> current_to;       ///< ports our current output is connected to once active
  double record_window_s = 0.0;  ///< > 0: frames recorded in windows this long (next_window), at most 60 s
};

/// A stretch of consecutive frames as the plant saw them.
struct RecordedWindow {
  std::uint64_t first_frame = 0;  ///< frames simulated before its first
  std::vector<double> drive;      ///< the drive received
  std::vector<double> sensor;     ///< the sensor's output (noise included)
  std::vector<double> clean;      ///< the plant's output without the sensor's noise (PlantSample::y_clean)
};

/// The virtual transducer running as a JACK client (active from construction to destruction).
class JackTransducer {
 public:
  /// Opens the client (never starting a server), registers the ports drive (in), sensor and current
  /// (out), activates it and makes the connections; throws std::runtime_error naming what failed.
  explicit JackTransducer(JackTransducerOptions options);
  /// Deactivates and closes the client.
  ~JackTransducer();
  JackTransducer(const JackTransducer&) = delete;
  JackTransducer& operator=(const JackTransducer&) = delete;

  /// The client's name as the server gave it.
  const std::string& name() const { return name_; }
  /// The full names of the ports ("<client>:drive", …).
  std::string drive_port() const { return name_ + ":drive"; }
  /// The sensor output's full name.
  std::string sensor_port() const { return name_ + ":sensor"; }
  /// The current output's full name.
  std::string current_port() const { return name_ + ":current"; }
  /// The server's rate, Hz (the plant runs at it).
  double rate() const { return rate_; }
  /// The plant as simulated (at the server's rate).
  const models::PlantConfig& plant() const { return transducer_->config(); }
  /// Frames simulated so far.
  std::uint64_t frames() const { return frames_.load(std::memory_order_relaxed); }
  /// The largest |drive| seen so far.
  double peak_drive() const { return peak_drive_.load(std::memory_order_relaxed); }
  /// True once the server has shut the client down.
  bool shut_down() const { return shut_down_.load(std::memory_order_relaxed); }
  /// Reader (one non-real-time thread): the oldest complete window not yet released, or nullptr; valid until
  /// release_window(). Windows follow each other without a gap unless the reader fell three behind.
  const RecordedWindow* next_window();
  /// Reader: hands the window next_window() returned back to the process callback.
  void release_window();
  /// Frames not recorded because every window was waiting for the reader.
  std::uint64_t dropped_frames() const { return dropped_frames_.load(std::memory_order_relaxed); }

 private:
  static int process(std::uint32_t frames, void* self) noexcept;
  static void on_shutdown(void* self) noexcept;
  void connect(const std::string& from, const std::string& to);

  void* client_ = nullptr;  // jack_client_t*
  void* drive_ = nullptr;   // jack_port_t*
  void* sensor_ = nullptr;
  void* current_ = nullptr;
  std::string name_;
  double rate_ = 0.0;
  void record(double drive, const models::PlantSample& s, std::uint64_t frame) noexcept;

  std::unique_ptr<models::VirtualTransducer> transducer_;
  // Windows: indices into windows_ go round free_ (reader → callback) and full_ (callback → reader).
  std::vector<RecordedWindow> windows_;
  SpscQueue<int, 4> free_, full_;
  int filling_ = -1;             // the callback's window (-1: none)
  std::size_t filled_ = 0;       // frames in it so far
  int reading_ = -1;             // the reader's window (-1: none)
  std::atomic<std::uint64_t> dropped_frames_{0};
  std::atomic<std::uint64_t> frames_{0};
  std::atomic<double> peak_drive_{0.0};
  std::atomic<bool> shut_down_{false};
};

}  // namespace panelbass::engine

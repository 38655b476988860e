#pragma once
// Is the sensor still there? A capture channel that goes silent (a cable pulled, a preamp off) reads
// zeros while the transducer plays; a feedback controller fed those zeros would fight a phantom. The
// watch compares what the sensor reads with what the plant model says it should read.

namespace panelbass::engine {

/// What counts as a silent sensor and for how long.
struct SensorWatchOptions {
  double silence = 1e-6;  ///< readings within ±silence are silent (raw sensor units)
  int timeout = 300;      ///< samples of silence (with the model predicting signal) before the sensor is lost, and of signal before it is back
};

/// Decides, sample by sample and without allocating, whether a sensor has gone silent and whether it
/// has come back.
class SensorWatch {
 public:
  /// A watch that considers the sensor present.
  explicit SensorWatch(SensorWatchOptions options = {}) : options_(options) {}

  /// One sample: what the sensor read and what the plant model predicted. The sensor is lost when it read
  /// silence for `timeout` samples in a row while the prediction's RMS over them exceeded 10·silence; it
  /// is back after `timeout` samples in a row above silence. Returns true when that state changed.
  bool update(double measured, double predicted) noexcept;
  /// True while the sensor is considered lost.
  bool lost() const noexcept { return lost_; }
  /// Present again, counters cleared.
  void reset() noexcept;

 private:
  SensorWatchOptions options_;
  bool lost_ = false;
  int run_ = 0;                   // consecutive samples supporting a change of state
  double predicted_energy_ = 0.0;  // Σ predicted² over the silent run
};

}  // namespace panelbass::engine

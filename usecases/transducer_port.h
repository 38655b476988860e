#pragma once
// The transducer a use case plays through, as its door provides it: a drive in, what was recorded out. The
// API's door plays through the server's backend (a sound card's measurement with its round trip removed, or the
// virtual transducer); the CLI's simulates a plant file.

#include <Eigen/Core>
#include <functional>
#include <nlohmann/json.hpp>

namespace panelbass::usecases {

/// What playing one drive recorded, each channel aligned to the drive and as long as it.
struct Playback {
  Eigen::VectorXd sensor;    ///< the sensor's output (an accelerometer on panel-exciter)
  Eigen::VectorXd current;   ///< the coil current, A; empty when nothing captures it
  Eigen::VectorXd loopback;  ///< the drive as the converters delivered it; empty when nothing loops it back
  nlohmann::json report;     ///< what the backend found playing it (a card's calibration); null when nothing
};

/// Plays a drive (every sample within the backend's safe level) and returns what was recorded; throws
/// std::runtime_error when the backend was interrupted.
using PlayFunction = std::function<Playback(const Eigen::VectorXd& drive)>;

}  // namespace panelbass::usecases

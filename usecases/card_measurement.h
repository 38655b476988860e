#pragma once
// The card measurement protocol (issue #55 Deliver 4), below both doors: the service's jobs measure through it
// (api/engine_service.h, EngineService::measure) and so does `panelbass measure --backend alsa`. A calibration
// sweep is played before and after the drive, the round trip found on the sweep before it (on the loopback channel,
// else the sensor), the loop checked sample by sample against the drive, and a slipped or interrupted measurement
// played again (three times at most); what comes back is each captured channel aligned to the drive.

#include <Eigen/Core>
#include <optional>
#include <string>

#include "engine/alsa_backend.h"
#include "usecases/transducer_port.h"

namespace panelbass::usecases {

/// How a measurement through a card is played.
struct CardMeasurementSettings {
  double fs = 0.0;            ///< the chain's rate, Hz (the drive's and the record's)
  double safe_level = 0.5;    ///< the largest drive peak the transducer may be played, (0, 1]
  double fade_seconds = 0.02;  ///< the program's fade out before the measurement and back in after it
};

/// Why a card with these channels cannot be measured through (it captures neither a sensor nor the drive's
/// loopback, so no round trip can be found), or nullopt when it can.
std::optional<std::string> card_cannot_measure(const engine::AlsaOptions& card);

/// Plays `drive` (every sample within the safe level) through `card` (started; its options `options`) by the
/// protocol above and returns the captured channels aligned to the drive (sensor, current, loopback: empty for a
/// channel the card does not capture) with the calibration's figures in Playback::report ({"calibrated_on",
/// "round_trip_samples", "round_trip_fractional", "round_trip_ms", "peak_correlation", "safe_level", "attempts",
/// "loop_residual", "played_s", "took_s"}). Throws std::invalid_argument for a drive beyond the safe level or a card
/// that cannot be measured through (card_cannot_measure), std::runtime_error when every attempt slipped or the device
/// did not stream again.
Playback measure_through_card(engine::AlsaBackend& card, const engine::AlsaOptions& options,
                              const CardMeasurementSettings& settings, const Eigen::VectorXd& drive);

}  // namespace panelbass::usecases

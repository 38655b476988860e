#pragma once
// `measure` / the excite job: an excitation played through a transducer (a sound card by the card measurement
// protocol, usecases/card_measurement.h, or the virtual transducer) and the record it gives, in an estimation and
// a validation part — the record the identify verbs read. The drive is uniform noise, a random-phase multisine,
// or a controller design's program through an LQ feedforward (its drive and per-sample harmonic weights).

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "models/control/feedback_design.h"
#include "usecases/progress.h"
#include "usecases/transducer_port.h"

namespace panelbass::usecases {

/// The fewest samples a record part may have.
inline constexpr long long kMinRecordSamples = 200;
/// The most samples a record part may have.
inline constexpr long long kMaxRecordSamples = 10'000'000;

/// What `measure` is asked.
struct ExciteRequest {
  std::string signal = "noise";         ///< "noise", "multisine" or "control"
  long long samples = 10000;            ///< the estimation part, samples
  long long validation_samples = 5000;  ///< the validation part (0: none)
  double amplitude = 0.3;               ///< the drive's peak, (0, safe_level] (not read for control)
  std::uint64_t seed = 1;               ///< the estimation part's; the validation part's is seed + 1
  double fs = 0.0;                      ///< the transducer's rate, Hz
  double safe_level = 1.0;              ///< the largest drive peak the transducer may be played, (0, 1]
  /// control: the LQ feedforward's file object whose drive for the design's program is played
  nlohmann::json feedforward_model;
  std::string feedforward_name;  ///< where it came from (a path, a stored id); empty: none
  double sine_peak = models::FeedbackDesignOptions{}.sine_peak;          ///< control: the stepped sines' peak
  double program_share = models::FeedbackDesignOptions{}.program_share;  ///< control: their share at a program level
};

/// The estimation and validation parts of a recording: raw drive u and response y.
struct ExcitationRecord {
  Eigen::VectorXd u_est, y_est, u_val, y_val;
  Eigen::VectorXd w_est, w_val;  ///< per-sample harmonic weights of a control excitation; empty otherwise
  Eigen::VectorXd i_est, i_val;  ///< the transducer's current, when captured; empty otherwise
  /// The drive as the converters delivered it (a sound card's loopback channel, the virtual transducer's
  /// converters alone), aligned like the response: the input of the process alone; empty otherwise.
  Eigen::VectorXd l_est, l_val;
  nlohmann::json card;  ///< measured through a sound card: each part's calibration report (null otherwise)
};

/// What `measure` recorded.
struct ExciteReport {
  ExcitationRecord record;  ///< the two parts
  /// {"fs","signal","amplitude","seed","samples","validation_samples","rms_drive","rms_response"}
  nlohmann::json summary;
};

/// Throws RequestError naming the field for a request out of range.
void check(const ExciteRequest& request);

/// The request's fields as the API names them (the excite job's params).
nlohmann::json to_json(const ExciteRequest& request);

/// The drive of one part of `request`'s noise or multisine (`samples` long, seeded `seed`), within [−1, 1].
Eigen::VectorXd excitation_signal(const ExciteRequest& request, Eigen::Index samples, std::uint64_t seed);

/// Plays the estimation part (seed), then the validation part (seed + 1), through `play`. Throws
/// std::runtime_error when the backend recorded no sensor, too few samples or a non-finite one.
ExciteReport excite(const ExciteRequest& request, const PlayFunction& play, Progress& progress);

}  // namespace panelbass::usecases

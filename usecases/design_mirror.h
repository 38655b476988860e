#pragma once
// `design mirror` / the design-mirror job: Klippel's mirror filter fitted to a record of drive, coil current and
// displacement (models/control/mirror_filter.h), or of the drive and the current alone (current_only,
// models/control/mirror_current_fit.h: what a sound card records), adaptive on line when a sensor column is given;
// a fit that misses says so, and with current_only is marked not usable.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/control/mirror_filter.h"
#include "models/control/mirror_observer.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// A fit whose residual (either equation) is above this share of its signal's power, percent, is reported as missing.
inline constexpr double kMirrorFitWarningPct = 5.0;

/// What `design mirror` is asked.
struct DesignMirrorRequest {
  Eigen::VectorXd drive, current;  ///< drive units, A; equally long, ≥ 1000 samples
  Eigen::VectorXd displacement;    ///< m, as long as the drive; not read with current_only
  Eigen::VectorXd sensor;  ///< the sensor's output; with adapt, or with current_only and a sensor_kind
  /// Fit from the drive and the current alone (mirror_current_fit.h): the motion is the back-EMF's, x a model state
  bool current_only = false;
  /// With current_only and a sensor: what it measures ("none", "acceleration", "velocity", "displacement",
  /// "microphone"); its scale, sign and delay are fitted
  std::string sensor_kind = "none";
  double fs = 0.0;         ///< Hz
  std::string data_name;   ///< where the record came from, kept in the model's meta
  int max_delay = 4;       ///< largest drive-to-voltage delay searched, samples (0..64)
  /// adapt on line: from the sensor (needs `sensor`), or with current_only from the coil current (the resistance,
  /// Bl(x), K(x) and the nonlinear shapes' scale; mirror_current_adapter.h)
  bool adapt = false;
  double stiffness_rate = models::MirrorObserverSettings{}.stiffness_rate;    ///< with adapt, ≥ 0
  double stiffness_spread = models::MirrorObserverSettings{}.stiffness_spread;  ///< with adapt, > 0
};

/// What `design mirror` made.
struct DesignMirrorReport {
  models::MirrorModel model;          ///< observer settings filled in with adapt
  nlohmann::json meta;                ///< the model file's meta
  nlohmann::json summary;             ///< the fit's figures
  std::vector<std::string> warnings;  ///< a fit that misses says so
  bool usable = true;                 ///< false when the current-only fit misses (its model is not to be used)
};

/// Throws RequestError naming the field for a request out of range.
void check(const DesignMirrorRequest& request);

/// The request's fields (the record by its name and length), as the API echoes its params.
nlohmann::json to_json(const DesignMirrorRequest& request);

/// Fits the model.
DesignMirrorReport design_mirror(const DesignMirrorRequest& request, Progress& progress);

}  // namespace panelbass::usecases

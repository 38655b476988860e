#pragma once
// `harmonics` / the harmonics job: harmonic distortion by stepped sine — of a plant simulated, or of a system
// played (a recording made with the stepped sine, a sound card) — and of a model beside it (thesis fig. 6.7),
// with how much of the measured distortion a canceller designed on that model would remove.

#include <Eigen/Core>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/plant/plant_config.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// What `harmonics` is asked: a plant or a system, and optionally a model.
struct HarmonicsRequest {
  std::optional<models::PlantConfig> plant;  ///< the plant simulated (its physics, noise off unless `noise`)
  /// Or a system played: the stepped sine's drive in, the response out (a recording's, a backend's).
  std::function<Eigen::VectorXd(const Eigen::VectorXd&)> system;
  double fs = 0.0;            ///< the system's rate, Hz (a plant's own otherwise)
  std::string source_name;    ///< what was measured ("panel-exciter", "rec.csv", "the sound card")
  nlohmann::json model;       ///< a plant model file object to compare (null: none)
  std::string model_name;     ///< where it came from
  std::vector<double> frequencies{40, 60, 80, 100, 150, 200, 300, 400, 600};  ///< fundamentals, Hz (> 0)
  std::vector<double> amplitudes{0.8};  ///< drive amplitudes within (0, 1]
  bool noise = false;         ///< keep a simulated plant's sensor noise
  long settle = 600;          ///< samples before each measured part
  long measure = 3000;        ///< measured samples per step
};

/// Throws RequestError naming the field for a request out of range.
void check(const HarmonicsRequest& request);

/// The request's fields (plant, system and model by their names), as the API echoes its params.
nlohmann::json to_json(const HarmonicsRequest& request);

/// The rows of the plant or system ("plant_rows" or "recording_rows"), the model's ("model_rows") and the
/// cancellable share per row ("cancellable", "smallest_cancellable_db") when a model is given.
nlohmann::json harmonics(const HarmonicsRequest& request, Progress& progress);

}  // namespace panelbass::usecases

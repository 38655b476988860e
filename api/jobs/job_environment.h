#pragma once
// What a job may use of the running service: the engine's rate, the backend to excite, the virtual
// transducer when that is the backend, the model store and the results of earlier jobs.

#include <Eigen/Core>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "api/jobs/excitation_record.h"
#include "api/model_store.h"
#include "api/record_store.h"
#include "engine/chain_file.h"
#include "models/plant/plant_config.h"

namespace panelbass::api {

/// What a job may use of the running service.
struct JobEnvironment {
  double fs = 3000.0;  ///< the engine's rate (every model a job makes runs at it)
  /// Plays `drive` (raw drive units, within [−1, 1]) through the active backend, bypassing the chain, and
  /// returns the recorded response, same length. Called from a worker thread.
  std::function<Eigen::VectorXd(const Eigen::VectorXd& drive)> excite;
  /// On a sound card: plays `drive` through it (program paused, chain bypassed, the round trip calibrated
  /// and removed) and returns the aligned response with its report; empty on the virtual transducer.
  std::function<MeasuredResponse(const Eigen::VectorXd& drive)> measure;
  /// The chain the engine runs now (band-pass, slots, limiter): what a job that verifies a controller runs offline.
  std::function<engine::ChainConfig()> chain;
  /// The largest drive peak the backend may be excited with (a sound card's configured safe level).
  double safe_level = 1.0;
  /// The virtual transducer when that is the backend (harmonic distortion, noise floor); empty otherwise.
  std::optional<models::PlantConfig> plant;
  /// The store: models a job reads ("plant_model", …) and the model it makes.
  ModelStore* store = nullptr;
  /// The result of a finished job (the "record" param of identify/analyze/diagnose); nullopt if unknown
  /// or not succeeded.
  std::function<std::optional<nlohmann::json>(const std::string& job_id)> job_result;
  /// Uploaded records (a "record" param naming "r…" instead of a job), and where an excite job keeps the record
  /// it made (once, not inside its job file); null when the service keeps none (an excite job's result then holds
  /// its record inline).
  RecordStore* records = nullptr;
};

}  // namespace panelbass::api

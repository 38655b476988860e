#pragma once
// `design nn` / the design-nn job: the neural feedback controller of the thesis's fig. 7.10 (App. 3), trained
// through the loop with a plant model (NARX or state space) behind an LQ feedforward, optionally tuned on a device
// (a virtual transducer standing in for the real one) or trained on from a controller. One request, its defaults
// written once (models::FeedbackDesignOptions's); both doors fill it and print or store the report.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/control/feedback_design.h"
#include "models/control/neural_feedback.h"
#include "models/plant/plant_config.h"
#include "usecases/band_pass.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// The largest input lag (nu, nv, ny) of the controller's network.
inline constexpr int kMaxControllerLag = 100;
/// The most trainings from fresh initial weights (each costs as much as the whole training).
inline constexpr int kMaxFeedbackRestarts = 20;
/// The most playbacks of each drive into the device tuned on (each costs a simulation of the record).
inline constexpr int kMaxDevicePlaybacks = 64;
/// The largest rail or drive-offset penalty.
inline constexpr double kMaxFeedbackPenalty = 1e12;

/// What `design nn` is asked.
struct DesignNnRequest {
  nlohmann::json plant_model;        ///< the plant model's file object: narx or ss
  std::string plant_name;            ///< where it came from (a path, a stored id), kept in the meta
  nlohmann::json feedforward_model;  ///< the LQ feedforward's file object (design lq)
  std::string feedforward_name;      ///< where it came from
  /// In front of the controllers; none: the one the feedforward was designed behind (its meta, band_pass_of)
  std::optional<BandPass> band_pass;
  /// The records, the network, the target, the training (its defaults are the models'; probe_hz empty: evaluate's)
  models::FeedbackDesignOptions design;
  /// A device to tune on (a virtual transducer standing in for the real one); none: the plant model alone
  std::optional<models::PlantConfig> tune_on;
  nlohmann::json start_from_model;  ///< a controller file to train on from (null: fresh initial weights)
  std::string start_from;           ///< its name (empty: none)
};

/// What `design nn` made.
struct DesignNnReport {
  models::NeuralFeedback controller;       ///< with its meta
  models::FeedbackTrainingResult training;  ///< the kept restart's history
  nlohmann::json summary;                  ///< the design's figures, as both doors give them
  nlohmann::json history;                  ///< [{"iteration","jc_est_pct","jc_val_pct","rail_fraction"}]
  double jc_est_pct = 0.0;                 ///< J_c on the estimation record at the kept parameters, percent
};

/// Throws RequestError naming the field for a request out of range (the model files are read by design_nn).
void check(const DesignNnRequest& request);

/// The request's fields with their values (the models by their names), as the API names them.
nlohmann::json to_json(const DesignNnRequest& request);

/// Trains the controller; RequestError naming "plant_model", "feedforward_model" or "start_from" for a file that is
/// not of the kind it should be.
DesignNnReport design_nn(const DesignNnRequest& request, Progress& progress);

}  // namespace panelbass::usecases

#pragma once
// `diagnose` / the diagnose job: where a simulation and a record disagree, the physics it leaves out, that physics
// modelled, and validation J before and after each finding (models/diagnosis/diagnosis.h does the work). Records at
// several drive levels: the loudest is diagnosed, the others' validation parts judge each finding at their level.

#include <Eigen/Core>
#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis.h"
#include "models/linear/linear_model.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// One record of a diagnosis: its estimation and validation parts (raw units, at the request's rate).
struct DiagnoseLevel {
  std::string name;                            ///< where it came from (a validation file, a record id)
  Eigen::VectorXd u_est, y_est, u_val, y_val;  ///< drive and response of each part
  Eigen::VectorXd i_est, i_val;                ///< the coil current of each part (both empty: the record has none)
};

/// What `diagnose` is asked.
struct DiagnoseRequest {
  std::vector<DiagnoseLevel> levels;  ///< one record, or records at several drive levels (the loudest is diagnosed)
  double fs = 0.0;                    ///< Hz
  std::optional<models::LinearModel> linear_baseline;          ///< the linear model diagnosed, or
  std::optional<models::SimulationBaseline> simulation_baseline;  ///< a simulation that is not linear (neither: the order scan's best OE model)
  std::string baseline_name;          ///< where the baseline came from (empty: the order scan)
  long init = 50;                     ///< measured outputs that set a simulation's state before J, 0..100000000
  int scan_from = 2;                  ///< without a baseline: the lowest OE order scanned, 1..60
  int scan_to = 14;                   ///< and the highest, scan_from..60
  int max_findings = 4;               ///< augmentation rounds at most, 0..20
  std::string sensor = "unknown";     ///< what the output measures: unknown, displacement, velocity or acceleration
  bool use_current = true;            ///< the record's coil current, when it has one, as the force channel
};

/// What `diagnose` found.
struct DiagnoseReport {
  models::Diagnosis diagnosis;     ///< the findings, the final model and the evidence
  nlohmann::json report;           ///< models::diagnosis_to_json's report, with "fs" and (from a baseline) "model"
  std::size_t diagnosed_level = 0;  ///< which of the request's levels was diagnosed (the loudest drive)
  nlohmann::json model_file;       ///< the diagnosed model as a gray_box model file (null: the baseline is not linear)
};

/// Throws RequestError naming the field for settings out of range (init, the scan, max_findings, sensor); the
/// records are not looked at (a door checks its settings before it has them).
void check_settings(const DiagnoseRequest& request);

/// Throws RequestError naming the field for a request out of range: its settings and its records.
void check(const DiagnoseRequest& request);

/// The request's settings and its baseline's name, as the API echoes its params.
nlohmann::json to_json(const DiagnoseRequest& request);

/// The sensor names `sensor` takes, in the order of models::OutputQuantity.
std::vector<std::string> sensor_names();

/// The index of the level with the loudest drive (mean square of its estimation part).
std::size_t loudest_level(const std::vector<DiagnoseLevel>& levels);

/// Diagnoses the loudest level's record; each stage is reported (no stage count is known ahead: each one closes part
/// of the gap to the end). Throws RequestError for a refused request, std::invalid_argument for unusable records.
DiagnoseReport diagnose(const DiagnoseRequest& request, Progress& progress);

}  // namespace panelbass::usecases

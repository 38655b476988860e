#pragma once
// `analyze` / the analyze job: the Analysis report of one plant model on one record — J by simulation ([2A], the
// first `init` measured outputs setting its state) and prediction, the residual tests, spectra, the measured and
// modelled frequency response, poles, zeros and root locus, J per training iteration, and with the plant at hand the
// harmonic distortion of plant and model (models::analyze_model).

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/analysis/model_analysis.h"
#include "models/plant/plant_config.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// What `analyze` is asked.
struct AnalyzeRequest {
  nlohmann::json model;    ///< the plant model file object (any plant kind)
  std::string model_name;  ///< where it came from (a path, a stored id)
  Eigen::VectorXd u, y;    ///< the record analysed: raw drive and response, at the model's rate
  std::string data_name;   ///< where it came from
  long init = 50;          ///< measured outputs that set the model's state, then free run; shorter than the record
  int lags = 20;           ///< lags of the residual correlation tests, 1..10000
  long segment = 0;        ///< Welch segment length (0: a power of 2 up to 4096, N/4), 0 or 16..16777216
  int refine_iterations = 20;  ///< a linear model without a history: OE iterations for the J figure (0: none), 0..10000
  std::vector<double> gain_range;  ///< root-locus gains {min, max}, raw units (empty: the stable interval around 0)
  std::optional<models::PlantConfig> plant;  ///< the plant the data came from: harmonic distortion, noise floor
  std::string plant_name;                    ///< its name (a preset, a file, "server")
  std::vector<double> frequencies{40.0, 80.0, 160.0, 320.0, 640.0};  ///< with a plant: stepped-sine frequencies, Hz
  std::vector<double> amplitudes{0.8};  ///< with a plant: drive amplitudes, (0, 1]
  long measure = 3000;                  ///< with a plant: samples measured per frequency, 100..10000000
  /// J per training iteration (none: the model file's meta.history, if any).
  std::optional<models::TrainingHistory> history;
};

/// What `analyze` found.
struct AnalyzeReport {
  models::ModelAnalysis analysis;  ///< the numbers, with the series the plots draw
  /// models::analysis_to_json() with {"model","data","plant"} (names; plant null without one).
  nlohmann::json summary;
};

/// Throws RequestError naming the field for a request out of range; the record's checks only once there is one.
void check(const AnalyzeRequest& request);

/// The request's fields (the model, record and plant by their names), as the API echoes its params.
nlohmann::json to_json(const AnalyzeRequest& request);

/// Analyses the model on the record.
AnalyzeReport analyze(const AnalyzeRequest& request, Progress& progress);

}  // namespace panelbass::usecases

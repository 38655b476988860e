#pragma once
// `validate` / the validate job: a plant model judged on a record by free-run simulation (J, [2A], the first
// `init` measured outputs setting its state) and by one-step prediction, with why the prediction may be worse.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>

#include "models/kinds/model_file.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// What `validate` is asked.
struct ValidateRequest {
  nlohmann::json model;    ///< the plant model file object (any plant kind)
  std::string model_name;  ///< where it came from (a path, a stored id)
  Eigen::VectorXd u, y;    ///< the record judged: raw drive and response, at the model's rate
  long init = 0;           ///< measured outputs that set the state before the free run (≥ 0, shorter than the record)
};

/// What `validate` found.
struct ValidateReport {
  nlohmann::json summary;      ///< {"J_sim_pct","J_pred_pct","J_pred_note","rmse","samples","kind","init","model"}
  Eigen::VectorXd y_sim, y_pred;  ///< the free run and the one-step prediction
};

/// Throws RequestError naming the field for a request out of range.
void check(const ValidateRequest& request);

/// The request's fields (the model by its name, the record by its length), as the API echoes its params.
nlohmann::json to_json(const ValidateRequest& request);

/// Judges the model.
ValidateReport validate_model(const ValidateRequest& request, Progress& progress);

}  // namespace panelbass::usecases

#pragma once
// `identify average` / the identify-average job: averaging restarts — the mean of ss models' free runs as one ss
// model (models/state_space_nn/ss_average), its members chosen by validation J when a validation record is given.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/state_space_nn/ss_model.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// What `identify average` is asked.
struct IdentifyAverageRequest {
  std::vector<models::SsModel> models;   ///< the candidates, ss models trained on the same estimation data
  std::vector<std::string> model_names;  ///< where each came from (a file, a stored model's id), as long as `models`
  Eigen::VectorXd u_val, y_val;          ///< validation record at the models' rate (empty: every candidate a member)
  std::string val_name;                  ///< where it came from
  long init = 50;                        ///< measured samples that set the state before J
};

/// What `identify average` made.
struct IdentifyAverageReport {
  models::SsModel model;              ///< the average, its meta filled in
  nlohmann::json summary;             ///< {"members","J_val_pct","candidates","states","params"}
  std::vector<std::string> warnings;  ///< a candidate's fitted initial state left out, …
};

/// Throws RequestError naming the field: fewer than one model, names that do not match them, a model that cannot
/// sit beside the first ("models": "<name> cannot be averaged with <first>: it …"), an init that leaves nothing.
void check(const IdentifyAverageRequest& request);

/// The request's fields (the models and the record by their names), as the API echoes its params.
nlohmann::json to_json(const IdentifyAverageRequest& request);

/// Averages the chosen members.
IdentifyAverageReport identify_average(const IdentifyAverageRequest& request, Progress& progress);

}  // namespace panelbass::usecases

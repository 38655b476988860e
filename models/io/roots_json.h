#pragma once
// The one way a list of poles or zeros is written into a report or a job's result.

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace panelbass::models {

/// `roots` as a JSON array of [re, im] pairs, in their order.
nlohmann::json roots_json(const Eigen::VectorXcd& roots);

}  // namespace panelbass::models

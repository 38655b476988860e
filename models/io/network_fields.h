#pragma once
// The JSON fields every network-based model file shares: hidden layer widths and the weight vector θ,
// read with the checks that keep a corrupt file from becoming a model.

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/io/json_fields.h"

namespace panelbass::models {

/// "hidden": a non-empty array of positive integer widths (bounded in count and size); ConfigError names
/// `path` (and the entry) when `v` is missing or wrong.
std::vector<int> read_hidden(const nlohmann::json* v, const std::string& path);

/// P for an MLP of `inputs` inputs and `hidden` widths, computed before any allocation.
std::int64_t parameter_count(int inputs, const std::vector<int>& hidden);

/// "theta": exactly `expected` finite numbers; ConfigError names `path` (and the entry).
Eigen::VectorXd read_theta(const nlohmann::json* v, const std::string& path, std::int64_t expected);

}  // namespace panelbass::models

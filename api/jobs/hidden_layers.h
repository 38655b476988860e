#pragma once
// A network's hidden layer widths as a job takes them ("hidden": [8, 4]) and names them ("[8,4]").

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "api/jobs/param_reader.h"

namespace panelbass::api {

/// Reads "hidden" of `r`: 1 to 4 layers of 1 to 256 nodes; `fallback` when absent.
std::vector<long long> hidden_layers(ParamReader& r, const std::vector<long long>& fallback);

/// The widths of checked params' "hidden" list.
std::vector<int> hidden_widths(const nlohmann::json& list);

/// "[8,4]".
std::string hidden_text(const std::vector<int>& hidden);

}  // namespace panelbass::api

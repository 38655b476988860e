#pragma once
// A multi-input multi-output linear state-space model as stored in a model file (kind "mimo"): the
// matrices in the data's own units, the sample rate, and the input and output column names.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/linear/mimo_state_space.h"

namespace panelbass::models {

/// A MIMO linear model in raw units (the data's), with the names of the channels it was identified on.
struct MimoModel {
  MimoStateSpace ss;                               ///< from raw inputs to raw outputs
  double fs = 0.0;                                 ///< sample rate it was identified at, Hz
  std::vector<std::string> inputs, outputs;        ///< column names, one per input and output
  nlohmann::json meta = nlohmann::json::object();  ///< provenance: data, order, J, …
};

/// The model file: {"format":"panelbass.model/1","kind":"mimo","fs","inputs":[…],"outputs":[…],
/// "params":{"order","A","B","C","D"} (matrices as arrays of rows),"meta"}.
nlohmann::json mimo_model_to_json(const MimoModel& m);

/// Reads a model file object and validates it: format and kind, channel names (non-empty, unique),
/// matrix shapes against the order and the channel counts, finite entries, fs > 0, and stability (every
/// pole strictly inside the unit circle); ConfigError names the key ("model.params.B[2]: expected 3
/// numbers, got 2", "model: unstable, pole radius 1.02").
MimoModel mimo_model_from_json(const nlohmann::json& j);

/// Writes a MIMO model file atomically; ConfigError naming the path if it cannot.
void save_mimo_model(const std::filesystem::path& path, const MimoModel& m);

/// Reads a MIMO model file; errors start with the file name.
MimoModel load_mimo_model(const std::filesystem::path& path);

}  // namespace panelbass::models

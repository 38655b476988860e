#pragma once
// The parts every model file shares ({"format":"panelbass.model/1","kind",…,"fs",…,"meta"}), read and
// checked in one place for every kind.

#include <nlohmann/json.hpp>
#include <string>

#include "models/io/json_fields.h"

namespace panelbass::models {

/// The format tag of every model file.
inline constexpr const char* kModelFormat = "panelbass.model/1";

/// Checks "format" and "kind" (== `kind`) of the model object behind `top` and returns its "fs" (> 0);
/// ConfigError names the key ("model.kind: expected \"narx\", got \"linear\"").
double read_model_header(JsonFields& top, const std::string& kind);

/// The required "params" object of the model behind `top`; ConfigError "model.params: missing" without one.
const nlohmann::json& read_model_params(JsonFields& top);

/// The optional "meta" object (an empty object when absent); ConfigError if it is not an object.
nlohmann::json read_model_meta(JsonFields& top);

}  // namespace panelbass::models

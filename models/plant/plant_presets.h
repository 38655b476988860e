#pragma once
// Built-in virtual transducers.

#include <string>
#include <vector>

#include "models/plant/plant_config.h"

namespace panelbass::models {

/// Names of the built-in plants ("panel-exciter", "linear").
std::vector<std::string> plant_preset_names();

/// The built-in plant `name`; throws ConfigError listing the names there are.
PlantConfig plant_preset(const std::string& name);

/// A preset name or a path to a plant JSON file.
PlantConfig plant_from_name_or_file(const std::string& name_or_path);

}  // namespace panelbass::models

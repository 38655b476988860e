// libFuzzer target: plant files (models/plant/plant_config.h plant_from_json). The input bytes are parsed as
// JSON first; a bad plant must be a ConfigError naming the key path, never a crash or any other exception.
// A plant that passes must survive its own JSON form unchanged (plant_to_json → plant_from_json).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "models/io/config_error.h"
#include "models/plant/plant_config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace panelbass::models;
  const nlohmann::json json = nlohmann::json::parse(data, data + size, nullptr, false);
  if (json.is_discarded()) return 0;
  PlantConfig plant;
  try {
    plant = plant_from_json(json);
  } catch (const ConfigError&) {
    return 0;
  }
  const nlohmann::json written = plant_to_json(plant);
  if (plant_to_json(plant_from_json(written)) != written) std::abort();  // a written plant must read back as itself
  return 0;
}

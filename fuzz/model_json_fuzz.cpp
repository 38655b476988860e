// libFuzzer target: model files (api/model_validation.h validate_model, which runs the loader of each
// kind: linear, narx, lq_feedforward, neural_feedback). The input bytes are parsed as JSON first; a bad
// model must be a ModelRejected naming the key path, never a crash, a hang or any other exception.
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>

#include "api/model_validation.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const nlohmann::json model = nlohmann::json::parse(data, data + size, nullptr, false);
  if (model.is_discarded()) return 0;
  try {
    (void)panelbass::api::validate_model(model);
  } catch (const panelbass::api::ModelRejected&) {
  }
  return 0;
}

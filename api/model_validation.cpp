#include "api/model_validation.h"

#include "engine/stage.h"
#include "models/kinds/model_file.h"

namespace panelbass::api {

ValidatedModel validate_model(const nlohmann::json& model) {
  try {
    const models::LoadedModel loaded = models::load_checked_model(model);
    // The engine's limit: a controller designed on a linear model has its states, and a huge delay would stall a
    // model swap (a stage realises max(na, nb + nk) states).
    if (const auto* linear = std::get_if<models::LinearModel>(&loaded)) {
      const Eigen::Index states = engine::linear_stage_states(linear->tf);
      if (states > engine::kMaxStageStates) {
        throw ModelRejected("invalid_model", "model.params: " + std::to_string(states) +
                                                 " states (max(na, nb + nk)) are more than the engine runs (" +
                                                 std::to_string(engine::kMaxStageStates) + ")");
      }
    }
    return {models::kind_of(loaded).name, models::rate_of(loaded)};
  } catch (const ModelRejected&) {
    throw;
  } catch (const models::UnsafeModel& e) {
    throw ModelRejected("invalid_model", e.what());
  } catch (const nlohmann::json::exception& e) {
    throw ModelRejected("bad_request", std::string("model: ") + e.what());
  } catch (const std::exception& e) {
    // models::ConfigError and std::invalid_argument name the key themselves.
    throw ModelRejected("bad_request", e.what());
  }
}

}  // namespace panelbass::api

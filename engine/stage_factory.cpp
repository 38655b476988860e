#include "engine/stage_factory.h"

#include <type_traits>

#include "engine/controller_stages.h"
#include "engine/mirror_filter_stage.h"
#include "models/io/config_error.h"

namespace panelbass::engine {

std::unique_ptr<Stage> make_stage(const nlohmann::json& model_file, models::ModelRole slot, FeedbackSource source) {
  const models::ModelKind& kind = models::model_kind_of(model_file);
  models::require_role(kind, slot, "the model");
  return std::visit(
      [source](auto&& m) -> std::unique_ptr<Stage> {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, models::LqFeedforward>) {
          return std::make_unique<StateSpaceStage>(m.controller(), m.fs);
        } else if constexpr (std::is_same_v<T, models::MirrorModel>) {
          return std::make_unique<MirrorFilterStage>(m);
        } else if constexpr (std::is_same_v<T, models::NeuralFeedback>) {
          return std::make_unique<NeuralFeedbackStage>(std::move(m), source);
        } else {
          // The registry gives plant kinds no slot: require_role refused it above.
          throw models::ConfigError("model: a plant model runs in no slot of the chain");
        }
      },
      models::load_checked_model(model_file));
}

double model_rate(const nlohmann::json& model_file) {
  if (!model_file.is_object() || !model_file.contains("fs") || !model_file["fs"].is_number()) {
    throw models::ConfigError("model.fs: missing or not a number");
  }
  return model_file["fs"].get<double>();
}

}  // namespace panelbass::engine

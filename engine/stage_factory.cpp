#include "engine/stage_factory.h"

#include <stdexcept>

#include "engine/controller_stages.h"
#include "engine/mirror_filter_stage.h"
#include "models/io/config_error.h"
#include "models/linear/linear_model.h"
#include "models/control/lq_feedforward.h"
#include "models/narx/narx_model.h"
#include "models/control/neural_feedback.h"

namespace panelbass::engine {

std::unique_ptr<Stage> make_stage(const nlohmann::json& model_file, FeedbackSource source) {
  if (!model_file.is_object() || !model_file.contains("kind") || !model_file["kind"].is_string()) {
    throw models::ConfigError("model: \"kind\" is missing or not a string");
  }
  const std::string kind = model_file["kind"].get<std::string>();
  if (kind == "linear") return std::make_unique<LinearStage>(models::linear_model_from_json(model_file));
  if (kind == "narx") return std::make_unique<NarxStage>(models::narx_model_from_json(model_file), source);
  if (kind == "lq_feedforward") {
    const models::LqFeedforward ff = models::lq_feedforward_from_json(model_file);
    return std::make_unique<StateSpaceStage>(ff.controller(), ff.fs);
  }
  if (kind == "mirror_filter") return std::make_unique<MirrorFilterStage>(models::mirror_model_from_json(model_file));
  if (kind == "neural_feedback") {
    return std::make_unique<NeuralFeedbackStage>(models::neural_feedback_from_json(model_file), source);
  }
  throw std::invalid_argument("model: kind \"" + kind + "\" cannot run as an engine stage");
}

double model_rate(const nlohmann::json& model_file) {
  if (!model_file.is_object() || !model_file.contains("fs") || !model_file["fs"].is_number()) {
    throw models::ConfigError("model.fs: missing or not a number");
  }
  return model_file["fs"].get<double>();
}

}  // namespace panelbass::engine

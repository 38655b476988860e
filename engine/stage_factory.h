#pragma once
// Stages from model files: the one place that knows which model kind becomes which stage, so the chain
// file, the CLI and the API build stages the same way.

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "engine/stage.h"

namespace panelbass::engine {

/// Builds the stage for a model file object of any kind the engine runs: "linear" (LinearStage),
/// "narx" (NarxStage, its past outputs from `source`), "lq_feedforward" (the [7B] controller u → u*) and
/// "neural_feedback" (the neural feedback controller; with FeedbackSource::model it runs its own copy of
/// the NARX plant model for y). Validates the object first; throws models::ConfigError naming what is
/// wrong, or std::invalid_argument for a kind the engine cannot run. The stage is not yet prepared.
std::unique_ptr<Stage> make_stage(const nlohmann::json& model_file, FeedbackSource source = FeedbackSource::model);

/// The sample rate a model file object declares ("fs"), Hz; throws models::ConfigError if it has none.
double model_rate(const nlohmann::json& model_file);

}  // namespace panelbass::engine

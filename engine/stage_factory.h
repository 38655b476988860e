#pragma once
// Stages from model files: the one place that knows which model kind runs as which stage. Which kinds a slot
// takes is the model-kind registry's (models/kinds/model_file.h); the chain file, the CLI and the API build
// stages here, so all of them refuse a kind in the wrong slot alike.

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "engine/stage.h"
#include "models/kinds/model_file.h"

namespace panelbass::engine {

/// Builds the stage of model file object `model_file` for the chain slot `slot` (ModelRole::feedforward or
/// ModelRole::feedback): "lq_feedforward" (the [7B] controller u → u*), "mirror_filter" (the mirror filter,
/// adaptive when its model carries a sensor map) and "neural_feedback" (with FeedbackSource::model it runs its own
/// copy of the NARX plant model for y). Loads and checks the file as the registry does; throws models::ConfigError
/// naming what is wrong (models::UnsafeModel for a model that runs away), a kind the slot does not take included.
/// The stage is not yet prepared.
std::unique_ptr<Stage> make_stage(const nlohmann::json& model_file, models::ModelRole slot,
                                  FeedbackSource source = FeedbackSource::model);

/// The sample rate a model file object declares ("fs"), Hz; throws models::ConfigError if it has none.
double model_rate(const nlohmann::json& model_file);

}  // namespace panelbass::engine

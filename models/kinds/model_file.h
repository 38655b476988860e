#pragma once
// Model files of every kind behind one loader (the shared contract: {"format":"panelbass.model/1",
// "kind": …}): what `validate`, the engine and the API read.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <variant>

#include "models/diagnosis/gray_box_model.h"
#include "models/linear/linear_model.h"
#include "models/narx/narx_model.h"
#include "models/oscillator/oscillator_model.h"
#include "models/state_space_nn/ss_model.h"

namespace panelbass::models {

/// A dynamic model of any kind, used through what all kinds can do.
struct AnyModel {
  std::variant<LinearModel, NarxModel, SsModel, GrayBoxModel, OscillatorModel> model;

  /// "linear", "narx", "ss", "gray_box" (a diagnosed linear model with gray-box terms) or "oscillator".
  std::string kind() const;
  /// Sample rate the model was identified at, Hz.
  double fs() const;
  /// Free-run simulation on raw data; the first `init` measured outputs set the state.
  Eigen::VectorXd simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y = {}, Eigen::Index init = 0) const;
  /// One-step (series-parallel) prediction on raw data.
  Eigen::VectorXd predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const;
};

/// Validates a model file object of any kind (dispatching on "kind"); ConfigError names what is wrong.
AnyModel model_from_json(const nlohmann::json& j);

/// Reads a model file of any kind; errors start with the file name.
AnyModel load_model(const std::filesystem::path& path);

/// Writes a NARX model file atomically; ConfigError naming the path if it cannot.
void save_narx_model(const std::filesystem::path& path, const NarxModel& m);

/// Writes a neural state-space model file atomically; ConfigError naming the path if it cannot.
void save_ss_model(const std::filesystem::path& path, const SsModel& m);

/// Writes an oscillator model file atomically; ConfigError naming the path if it cannot.
void save_oscillator_model(const std::filesystem::path& path, const OscillatorModel& m);

}  // namespace panelbass::models

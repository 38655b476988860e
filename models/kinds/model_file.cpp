#include "models/kinds/model_file.h"

#include "models/io/config_error.h"
#include "models/io/json_file.h"

namespace panelbass::models {

std::string AnyModel::kind() const {
  if (std::holds_alternative<LinearModel>(model)) return "linear";
  if (std::holds_alternative<GrayBoxModel>(model)) return "gray_box";
  if (std::holds_alternative<OscillatorModel>(model)) return "oscillator";
  return std::holds_alternative<NarxModel>(model) ? "narx" : "ss";
}

double AnyModel::fs() const {
  return std::visit([](const auto& m) { return m.fs; }, model);
}

Eigen::VectorXd AnyModel::simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) const {
  return std::visit([&](const auto& m) { return m.simulate(u, y, init); }, model);
}

Eigen::VectorXd AnyModel::predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const {
  return std::visit([&](const auto& m) { return m.predict(u, y); }, model);
}

AnyModel model_from_json(const nlohmann::json& j) {
  if (!j.is_object()) throw ConfigError("model: expected an object");
  const auto kind = j.find("kind");
  if (kind == j.end() || !kind->is_string()) throw ConfigError("model.kind: missing (linear, narx, ss, gray_box or oscillator)");
  if (*kind == "linear") return AnyModel{linear_model_from_json(j)};
  if (*kind == "narx") return AnyModel{narx_model_from_json(j)};
  if (*kind == "ss") return AnyModel{ss_model_from_json(j)};
  if (*kind == "gray_box") return AnyModel{gray_box_model_from_json(j)};
  if (*kind == "oscillator") return AnyModel{oscillator_model_from_json(j)};
  if (*kind == "mimo") {
    throw ConfigError("model.kind: \"mimo\" is a multi-input multi-output model; only `panelbass validate` reads it "
                      "(on periodic data), this takes single-input single-output models (linear, narx, ss, gray_box or oscillator)");
  }
  throw ConfigError("model.kind: unknown kind \"" + kind->get<std::string>() + "\" (linear, narx, ss, gray_box or oscillator)");
}

AnyModel load_model(const std::filesystem::path& path) {
  return read_json_file_as(path, model_from_json);
}

void save_narx_model(const std::filesystem::path& path, const NarxModel& m) {
  write_json_file(path, narx_model_to_json(m));
}

void save_ss_model(const std::filesystem::path& path, const SsModel& m) { write_json_file(path, ss_model_to_json(m)); }

void save_oscillator_model(const std::filesystem::path& path, const OscillatorModel& m) {
  write_json_file(path, oscillator_model_to_json(m));
}

}  // namespace panelbass::models

#pragma once
// Model files of every kind behind one registry (the shared contract: {"format":"panelbass.model/1",
// "kind": …}): for each kind its name, what it is in words, the roles it may take (a plant description, the
// engine's feedforward or feedback slot), its loader with the kind's own checks, the lenient stability check
// that tells an unsafe model from a malformed one, and its writer. `validate`, the engine's stage factory, the
// chain file, the API's store and every verb ask it; nothing else lists kinds.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "models/control/lq_feedforward.h"
#include "models/control/mirror_filter.h"
#include "models/control/neural_feedback.h"
#include "models/diagnosis/gray_box_model.h"
#include "models/io/config_error.h"
#include "models/linear/linear_model.h"
#include "models/narx/narx_model.h"
#include "models/oscillator/oscillator_model.h"
#include "models/state_space_nn/ss_model.h"

namespace panelbass::models {

/// What a model can be used as: a description of the transducer (simulated, validated, designed on), or a
/// controller in one of the engine chain's two slots.
enum class ModelRole : unsigned { plant = 1u, feedforward = 2u, feedback = 4u };

/// Every role, as a mask.
inline constexpr unsigned kAnyRole = 7u;

/// "plant", "feedforward" or "feedback".
const char* role_name(ModelRole role);

/// A model file of any kind, read and checked.
using LoadedModel =
    std::variant<LinearModel, NarxModel, SsModel, GrayBoxModel, OscillatorModel, LqFeedforward, MirrorModel, NeuralFeedback>;

/// A model file that parses but is unsafe to simulate or run: a non-finite number, an unstable pole, a free run
/// or closed loop that runs away. The message names the key path. (A ConfigError, so a caller that does not
/// tell the two apart still catches it.)
class UnsafeModel : public ConfigError {
 public:
  using ConfigError::ConfigError;
};

/// One kind of model file: all a door needs to know of it.
struct ModelKind {
  const char* name;      ///< as the file's "kind" spells it ("linear")
  const char* in_words;  ///< "a linear plant model"
  unsigned roles;        ///< ModelRole bits
  /// The kind's loader with its own checks (shape, finiteness, stability, bounded run); ConfigError naming the
  /// key, UnsafeModel for what parses but runs away.
  LoadedModel (*load)(const nlohmann::json& file);
  /// The lenient stability check run before the loader (nullptr: none), so that an unsafe model is told from a
  /// malformed one: the problem, naming the key path; nullopt when safe or unreadable (the loader then names it).
  std::optional<std::string> (*unsafe)(const nlohmann::json& file);
  /// The model file object of a model of this kind.
  nlohmann::json (*write)(const LoadedModel& model);
  /// True when a model of this kind may take `role`.
  bool takes(ModelRole role) const { return (roles & static_cast<unsigned>(role)) != 0u; }
};

/// Every kind, in the order messages list them.
const std::vector<ModelKind>& model_kinds();

/// The names of the kinds that may take any role of `roles`, as "a, b or c".
std::string model_kind_names(unsigned roles = kAnyRole);

/// The kind named `name`, or nullptr.
const ModelKind* find_model_kind(const std::string& name);

/// The kind of model file object `file` ("model.kind: …" ConfigError naming the known kinds otherwise, and
/// what the file is when it is another panelbass file: a plant description, a chain).
const ModelKind& model_kind_of(const nlohmann::json& file);

/// Reads and checks a model file object of any kind: the first non-finite number (UnsafeModel naming its key
/// path), the kind's stability (UnsafeModel), then the kind's loader (ConfigError naming the key).
LoadedModel load_checked_model(const nlohmann::json& file);

/// The kind of a loaded model.
const ModelKind& kind_of(const LoadedModel& model);

/// The sample rate a loaded model runs at, Hz.
double rate_of(const LoadedModel& model);

/// Writes a model file of any kind atomically; ConfigError naming the path if it cannot.
void save_model(const std::filesystem::path& path, const LoadedModel& model);

/// Throws ConfigError unless a model of `kind` may take `role`: "<where>: <id> is a linear plant model (kind
/// linear): the feedforward slot takes lq_feedforward or mirror_filter" and what the model is for instead.
void require_role(const ModelKind& kind, ModelRole role, const std::string& where);

/// A dynamic model of any plant kind, used through what all of them can do.
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

/// Validates a model file object of a plant kind (a controller or an unknown kind is a ConfigError naming the
/// plant kinds).
AnyModel model_from_json(const nlohmann::json& j);

/// Reads a model file of a plant kind; errors start with the file name.
AnyModel load_model(const std::filesystem::path& path);

/// Writes a NARX model file atomically; ConfigError naming the path if it cannot.
void save_narx_model(const std::filesystem::path& path, const NarxModel& m);

/// Writes a neural state-space model file atomically; ConfigError naming the path if it cannot.
void save_ss_model(const std::filesystem::path& path, const SsModel& m);

/// Writes an oscillator model file atomically; ConfigError naming the path if it cannot.
void save_oscillator_model(const std::filesystem::path& path, const OscillatorModel& m);

}  // namespace panelbass::models

#include "models/kinds/model_file.h"

#include <type_traits>
#include <utility>

#include "models/io/json_file.h"
#include "models/io/number_text.h"
#include "models/kinds/model_checks.h"

namespace panelbass::models {
namespace {

using nlohmann::json;

// The writer of kind T: the file object of the model the variant holds.
template <typename T, json (*to_json)(const T&)>
json write_as(const LoadedModel& model) {
  return to_json(std::get<T>(model));
}

json write_mirror(const LoadedModel& model) { return mirror_model_to_json(std::get<MirrorModel>(model)); }

template <typename T, T (*from_json)(const json&)>
LoadedModel load_as(const json& file) {
  return from_json(file);
}

std::optional<std::string> ss_unsafety(const json& file) {
  try {
    return runaway_problem(ss_free_run_runaway(ss_model_shape_from_json(file)), "model", "the free run");
  } catch (...) {
    return std::nullopt;  // malformed: the loader names it
  }
}

std::optional<std::string> neural_feedback_unsafety(const json& file) {
  if (!file.is_object() || !file.contains("plant")) return std::nullopt;
  return narx_unsafety(file["plant"], "model.plant");
}

// The neural feedback controller with its plant model in closed loop (fig. 7.10) on full-scale drive noise must
// stay bounded.
LoadedModel load_neural_feedback(const json& file) {
  NeuralFeedback c = neural_feedback_from_json(file);
  if (auto problem = runaway_problem(closed_loop_runaway(c), "model", "the closed loop with its plant model")) {
    throw UnsafeModel(*problem);
  }
  return c;
}

// The mirror filter run as the engine runs it, on full-scale uniform noise, must give a finite drive.
LoadedModel load_mirror(const json& file) {
  MirrorModel m = mirror_model_from_json(file);
  const Eigen::VectorXd drive = mirror_filter(m, free_run_drive());
  if (!drive.allFinite()) {
    throw UnsafeModel("model: unstable: the mirror filter on full-scale uniform noise gives a non-finite drive");
  }
  return m;
}

constexpr unsigned kPlant = static_cast<unsigned>(ModelRole::plant);
constexpr unsigned kFeedforward = static_cast<unsigned>(ModelRole::feedforward);
constexpr unsigned kFeedback = static_cast<unsigned>(ModelRole::feedback);

}  // namespace

const char* role_name(ModelRole role) {
  switch (role) {
    case ModelRole::plant: return "plant";
    case ModelRole::feedforward: return "feedforward";
    case ModelRole::feedback: return "feedback";
  }
  return "?";
}

const std::vector<ModelKind>& model_kinds() {
  static const std::vector<ModelKind> kinds{
      {"linear", "a linear plant model", kPlant, load_as<LinearModel, linear_model_from_json>, linear_unsafety,
       write_as<LinearModel, linear_model_to_json>},
      {"narx", "a NARX plant model", kPlant, load_as<NarxModel, narx_model_from_json>,
       [](const json& file) { return narx_unsafety(file, "model"); }, write_as<NarxModel, narx_model_to_json>},
      {"ss", "a neural state-space plant model", kPlant, load_as<SsModel, ss_model_from_json>, ss_unsafety,
       write_as<SsModel, ss_model_to_json>},
      {"gray_box", "a diagnosed gray-box plant model", kPlant, load_as<GrayBoxModel, gray_box_model_from_json>, nullptr,
       write_as<GrayBoxModel, gray_box_model_to_json>},
      {"oscillator", "an oscillator plant model", kPlant, load_as<OscillatorModel, oscillator_model_from_json>, nullptr,
       write_as<OscillatorModel, oscillator_model_to_json>},
      {"lq_feedforward", "an LQ feedforward controller", kFeedforward, load_as<LqFeedforward, lq_feedforward_from_json>,
       lq_unsafety, write_as<LqFeedforward, lq_feedforward_to_json>},
      {"mirror_filter", "a mirror filter (the inverse of a gray-box exciter model)", kFeedforward, load_mirror, nullptr,
       write_mirror},
      {"neural_feedback", "a neural feedback controller", kFeedback, load_neural_feedback, neural_feedback_unsafety,
       write_as<NeuralFeedback, neural_feedback_to_json>},
  };
  return kinds;
}

std::string model_kind_names(unsigned roles) {
  std::vector<const char*> names;
  for (const ModelKind& k : model_kinds()) {
    if ((k.roles & roles) != 0u) names.push_back(k.name);
  }
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += i + 1 == names.size() ? " or " : ", ";
    out += names[i];
  }
  return out;
}

const ModelKind* find_model_kind(const std::string& name) {
  for (const ModelKind& k : model_kinds()) {
    if (name == k.name) return &k;
  }
  return nullptr;
}

const ModelKind& model_kind_of(const json& file) {
  if (!file.is_object()) throw ConfigError(std::string("model: expected a JSON object, got ") + file.type_name());
  const auto it = file.find("kind");
  if (it == file.end()) {
    // Another panelbass file sent where a model belongs: say what it is.
    const auto format = file.find("format");
    const std::string tag = format != file.end() && format->is_string() ? format->get<std::string>() : "";
    if (tag == "panelbass.plant/1") {
      throw ConfigError("model: this is a plant description (\"format\":\"panelbass.plant/1\": the virtual transducer's "
                        "physics), not a model file; it belongs to --plant of panelbass serve, run, simulate or "
                        "transducer. Models are what identify and design make (\"format\":\"panelbass.model/1\")");
    }
    if (tag == "panelbass.chain/1") {
      throw ConfigError("model: this is a chain file (\"format\":\"panelbass.chain/1\"), not a model file; it belongs to "
                        "panelbass run --chain or render --chain (over the API, set the chain with PUT /api/config)");
    }
    throw ConfigError("model.kind: missing (a model file has \"format\":\"panelbass.model/1\" and \"kind\": " +
                      model_kind_names() + ")");
  }
  if (!it->is_string()) throw ConfigError(std::string("model.kind: expected a string, got ") + it->type_name());
  const std::string name = it->get<std::string>();
  if (const ModelKind* kind = find_model_kind(name)) return *kind;
  if (name == "mimo") {
    throw ConfigError("model.kind: \"mimo\" is a multi-input multi-output model; only `panelbass validate` reads it (on "
                      "periodic data), this takes single-input single-output models (" + model_kind_names() + ")");
  }
  throw ConfigError("model.kind: unknown kind \"" + name + "\" (expected " + model_kind_names() + ")");
}

LoadedModel load_checked_model(const json& file) {
  const ModelKind& kind = model_kind_of(file);
  if (const auto bad = first_non_finite(file, "model")) {
    throw UnsafeModel(bad->first + ": not finite (" + number_text(bad->second) + ")");
  }
  if (kind.unsafe != nullptr) {
    if (auto problem = kind.unsafe(file)) throw UnsafeModel(*problem);
  }
  return kind.load(file);
}

const ModelKind& kind_of(const LoadedModel& model) {
  const ModelKind& kind = model_kinds().at(model.index());
  return kind;
}

double rate_of(const LoadedModel& model) {
  return std::visit([](const auto& m) { return m.fs; }, model);
}

void save_model(const std::filesystem::path& path, const LoadedModel& model) {
  write_json_file(path, kind_of(model).write(model));
}

void require_role(const ModelKind& kind, ModelRole role, const std::string& where) {
  if (kind.takes(role)) return;
  std::string message = where + " is " + kind.in_words + " (kind " + kind.name + "): ";
  message += role == ModelRole::plant ? std::string("a plant model is needed (kind ") + model_kind_names(kPlant) + ")"
                                      : std::string("the ") + role_name(role) + " slot takes " +
                                            model_kind_names(static_cast<unsigned>(role));
  if (kind.takes(ModelRole::plant)) {
    message += "; a plant model is what controllers are designed on (design lq, design nn, design mirror)";
  } else if (kind.takes(ModelRole::feedforward)) {
    message += "; it goes in the feedforward slot";
  } else if (kind.takes(ModelRole::feedback)) {
    message += "; it goes in the feedback slot";
  }
  throw ConfigError(message);
}

// AnyModel's kinds are LoadedModel's first ones, in the same order, so that an index names the kind in both.
template <std::size_t... I>
constexpr bool same_first_kinds(std::index_sequence<I...>) {
  return (std::is_same_v<std::variant_alternative_t<I, decltype(AnyModel::model)>, std::variant_alternative_t<I, LoadedModel>> && ...);
}
static_assert(same_first_kinds(std::make_index_sequence<std::variant_size_v<decltype(AnyModel::model)>>{}));

std::string AnyModel::kind() const { return model_kinds().at(model.index()).name; }

double AnyModel::fs() const {
  return std::visit([](const auto& m) { return m.fs; }, model);
}

Eigen::VectorXd AnyModel::simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) const {
  return std::visit([&](const auto& m) { return m.simulate(u, y, init); }, model);
}

Eigen::VectorXd AnyModel::predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const {
  return std::visit([&](const auto& m) { return m.predict(u, y); }, model);
}

AnyModel model_from_json(const json& j) {
  const ModelKind& kind = model_kind_of(j);
  if (!kind.takes(ModelRole::plant)) {
    throw ConfigError(std::string("model.kind: \"") + kind.name + "\" is " + kind.in_words +
                      ", not a model of the transducer; this takes a plant model (" + model_kind_names(kPlant) + ")");
  }
  const LoadedModel loaded = kind.load(j);
  return std::visit(
      [](const auto& m) -> AnyModel {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, LqFeedforward> || std::is_same_v<T, MirrorModel> || std::is_same_v<T, NeuralFeedback>) {
          throw ConfigError("model: not a plant model");  // unreachable: the roles say so
        } else {
          return AnyModel{m};
        }
      },
      loaded);
}

AnyModel load_model(const std::filesystem::path& path) { return read_json_file_as(path, model_from_json); }

void save_narx_model(const std::filesystem::path& path, const NarxModel& m) { write_json_file(path, narx_model_to_json(m)); }

void save_ss_model(const std::filesystem::path& path, const SsModel& m) { write_json_file(path, ss_model_to_json(m)); }

void save_oscillator_model(const std::filesystem::path& path, const OscillatorModel& m) {
  write_json_file(path, oscillator_model_to_json(m));
}

}  // namespace panelbass::models

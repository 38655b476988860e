#include "api/model_validation.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "engine/chain_file.h"
#include "engine/stage.h"
#include "models/io/config_error.h"
#include "models/kinds/model_checks.h"
#include "models/linear/linear_model.h"
#include "models/control/lq_feedforward.h"
#include "models/oscillator/oscillator_model.h"
#include "models/narx/narx_model.h"
#include "models/state_space_nn/ss_model.h"
#include "models/io/network_fields.h"
#include "models/control/neural_feedback.h"
#include "models/diagnosis/gray_box_model.h"
#include "models/preprocess/scaling.h"
#include "models/io/number_text.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

constexpr const char* kBadRequest = "bad_request";
constexpr const char* kInvalidModel = "invalid_model";

std::string show(double v) { return models::number_text(v); }

// The kind of `model`, or ModelRejected("bad_request") naming "model.kind".
std::string read_kind(const json& model) {
  if (!model.is_object()) {
    throw ModelRejected(kBadRequest, std::string("model: expected a JSON object, got ") + model.type_name());
  }
  const auto it = model.find("kind");
  if (it == model.end()) {
    // Another panelbass file sent where a model belongs: say what it is and where it goes.
    const auto format = model.find("format");
    const std::string tag = format != model.end() && format->is_string() ? format->get<std::string>() : "";
    if (tag == "panelbass.plant/1") {
      throw ModelRejected(kBadRequest,
                          "model: this is a plant description (\"format\":\"panelbass.plant/1\": the virtual "
                          "transducer's physics), not a model file; it belongs to --plant of panelbass serve, run or "
                          "simulate. Models are what identify and design make (\"format\":\"panelbass.model/1\")");
    }
    if (tag == engine::kChainFormat) {
      throw ModelRejected(kBadRequest,
                          "model: this is a chain file (\"format\":\"panelbass.chain/1\"), not a model file; it "
                          "belongs to panelbass run --chain (over the API, set the chain with PUT /api/config)");
    }
    throw ModelRejected(kBadRequest, "model.kind: missing (a model file has \"format\":\"panelbass.model/1\" and "
                                     "\"kind\": linear, narx, ss, lq_feedforward, neural_feedback, gray_box or oscillator)");
  }
  if (!it->is_string()) {
    throw ModelRejected(kBadRequest, std::string("model.kind: expected a string, got ") + it->type_name());
  }
  const std::string kind = it->get<std::string>();
  for (const char* known : {"linear", "narx", "ss", "lq_feedforward", "neural_feedback", "gray_box", "oscillator"}) {
    if (kind == known) return kind;
  }
  throw ModelRejected(kBadRequest, "model.kind: unknown kind \"" + kind +
                                       "\" (expected linear, narx, ss, lq_feedforward, neural_feedback, gray_box or oscillator)");
}

// The key path of the first non-finite number in `root` (depth first, object keys in their stored
// order), with an explicit stack so that a deeply nested body cannot overflow the thread's stack.
std::optional<std::pair<std::string, double>> first_non_finite(const json& root, const std::string& root_path) {
  std::vector<std::pair<const json*, std::string>> stack{{&root, root_path}};
  while (!stack.empty()) {
    auto [value, path] = std::move(stack.back());
    stack.pop_back();
    if (value->is_number_float()) {
      const double v = value->get<double>();
      if (!std::isfinite(v)) return std::pair{path, v};
    } else if (value->is_object()) {
      std::vector<std::pair<const json*, std::string>> children;
      for (auto it = value->begin(); it != value->end(); ++it) children.emplace_back(&*it, path + "." + it.key());
      stack.insert(stack.end(), children.rbegin(), children.rend());
    } else if (value->is_array()) {
      for (std::size_t i = value->size(); i-- > 0;) {
        stack.emplace_back(&(*value)[i], path + "[" + std::to_string(i) + "]");
      }
    }
  }
  return std::nullopt;
}

// A JSON array of numbers as a vector; throws (any exception: the loader names the problem) otherwise.
Eigen::VectorXd numbers(const json& v) {
  if (!v.is_array()) throw std::invalid_argument("not an array");
  Eigen::VectorXd out(static_cast<Eigen::Index>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!v[i].is_number()) throw std::invalid_argument("not a number");
    out[static_cast<Eigen::Index>(i)] = v[i].get<double>();
  }
  return out;
}

std::string pole_problem(const std::string& path, double radius, double hz) {
  return path + ": unstable: pole at |z| = " + show(radius) + (std::isfinite(hz) ? " (" + show(hz) + " Hz)" : "");
}

// Linear: the poles, roots of z^na·A(z), must lie strictly inside the unit circle.
std::optional<std::string> linear_instability(const json& model) {
  models::TransferFunction tf;
  tf.a = numbers(model.at("params").at("a"));
  tf.b = Eigen::VectorXd::Ones(1);
  const double fs = model.contains("fs") && model["fs"].is_number() ? model["fs"].get<double>() : NAN;
  const std::optional<models::UnstablePole> pole = models::unstable_pole(tf, fs);
  if (!pole) return std::nullopt;
  return pole_problem("model.params.a", pole->radius, pole->hz);
}

// LQ feedforward: the controller runs x(k+1) = (A − B·L)·x(k) + B·u(k); its spectral radius must be < 1.
std::optional<std::string> lq_instability(const json& model) {
  const json& params = model.at("params");
  const json& a = params.at("A");
  if (!a.is_array()) return std::nullopt;
  const auto n = static_cast<Eigen::Index>(a.size());
  Eigen::MatrixXd A(n, n);
  for (Eigen::Index r = 0; r < n; ++r) {
    const Eigen::VectorXd row = numbers(a[static_cast<std::size_t>(r)]);
    if (row.size() != n) return std::nullopt;
    A.row(r) = row.transpose();
  }
  const Eigen::VectorXd B = numbers(params.at("B"));
  const Eigen::VectorXd L = numbers(params.at("L"));
  if (B.size() != n || L.size() != n || n == 0) return std::nullopt;
  const std::optional<double> radius = models::unstable_lq_radius(A, B, L);
  if (!radius) return std::nullopt;
  return "model.params: unstable: pole of A − B·L at |z| = " + show(*radius);
}

// A free run's runaway as a problem of the model at `path`.
std::optional<std::string> runaway_problem(const std::optional<models::Runaway>& run, const std::string& path,
                                           const std::string& what) {
  if (!run) return std::nullopt;
  return path + ": unstable: " + what + " on uniform noise leaves ±" + show(models::kFreeRunBound) +
         " output ranges (|y| = " + show(run->magnitude) + " after " + std::to_string(run->samples) + " samples)";
}

// NARX (at `path`, e.g. "model" or "model.plant"): a free run on uniform noise spanning the scaled input
// range [−1, 1] must stay finite and within 100 output ranges. Read leniently: what does not parse is left
// for the loader to name.
std::optional<std::string> narx_instability(const json& model, const std::string& path) {
  const models::Scaling scaling = models::scaling_from_json(model.at("scaling"), path + ".scaling");
  const json& params = model.at("params");
  models::NarxStructure s;
  // Orders beyond these are a corrupt file (the loader's limits say which).
  const auto order = [&params](const char* key, std::int64_t hi) {
    const json& v = params.at(key);
    if (!v.is_number_integer()) throw std::invalid_argument("not an integer");
    const std::int64_t n = v.get<std::int64_t>();
    if (n < 0 || n > hi) throw std::invalid_argument("out of range");
    return static_cast<int>(n);
  };
  s.na = order("na", 999);
  s.nb = order("nb", 999);
  // Any delay of the whole run or more gives the same run: the input never arrives.
  s.nk = static_cast<int>(std::min<std::int64_t>(order("nk", 384000L * 60L), models::kFreeRunSamples));
  if (s.inputs() > 1000) return std::nullopt;
  s.hidden = models::read_hidden(params.contains("hidden") ? &params["hidden"] : nullptr, path + ".params.hidden");
  const std::int64_t count = models::parameter_count(s.inputs(), s.hidden);
  const Eigen::VectorXd theta =
      models::read_theta(params.contains("theta") ? &params["theta"] : nullptr, path + ".params.theta", count);
  models::NarxModel m = models::NarxModel::with_structure(s, scaling, 1.0);
  m.net.parameters() = theta;
  return runaway_problem(models::free_run_runaway(m), path, "the free run");
}

// The stability problem of `model`, if its shape is readable enough to tell; nullopt otherwise.
std::optional<std::string> instability(const std::string& kind, const json& model) {
  try {
    if (kind == "linear") return linear_instability(model);
    if (kind == "lq_feedforward") return lq_instability(model);
    if (kind == "narx") return narx_instability(model, "model");
    if (kind == "ss") {
      return runaway_problem(models::ss_free_run_runaway(models::ss_model_shape_from_json(model)), "model",
                             "the free run");
    }
    if (kind == "neural_feedback") return narx_instability(model.at("plant"), "model.plant");
  } catch (...) {
    // Malformed: the kind's loader says what is wrong, as a bad request.
  }
  return std::nullopt;
}

// The controller and its plant model in closed loop (fig. 7.10) on full-scale drive noise must stay bounded.
void require_bounded_closed_loop(const models::NeuralFeedback& c) {
  if (auto problem = runaway_problem(models::closed_loop_runaway(c), "model", "the closed loop with its plant model")) {
    throw ModelRejected(kInvalidModel, *problem);
  }
}

// Runs the kind's loader (format, fields, dimensions) and returns the model's rate.
double load(const std::string& kind, const json& model) {
  if (kind == "linear") {
    const models::LinearModel m = models::linear_model_from_json(model);
    // The engine's limit (a huge delay would stall the model swap).
    const Eigen::Index states = engine::linear_stage_states(m.tf);
    if (states > engine::kMaxLinearStageStates) {
      throw ModelRejected(kInvalidModel, "model.params: " + std::to_string(states) +
                                             " states (max(na, nb + nk)) are more than the engine runs (" +
                                             std::to_string(engine::kMaxLinearStageStates) + ")");
    }
    return m.fs;
  }
  if (kind == "narx") return models::narx_model_from_json(model).fs;
  if (kind == "ss") return models::ss_model_from_json(model).fs;
  if (kind == "gray_box") return models::gray_box_model_from_json(model).fs;  // its linear part's stability checked
  if (kind == "oscillator") return models::oscillator_model_from_json(model).fs;  // its free run checked
  if (kind == "lq_feedforward") return models::lq_feedforward_from_json(model).fs;
  const models::NeuralFeedback c = models::neural_feedback_from_json(model);
  require_bounded_closed_loop(c);
  return c.fs;
}

}  // namespace

ValidatedModel validate_model(const json& model) {
  ValidatedModel out;
  out.kind = read_kind(model);
  // Before the loader: it would call a non-finite number or an unstable model malformed (bad_request),
  // while the API answers both with invalid_model.
  if (const auto bad = first_non_finite(model, "model")) {
    throw ModelRejected(kInvalidModel, bad->first + ": not finite (" + show(bad->second) + ")");
  }
  if (const auto problem = instability(out.kind, model)) throw ModelRejected(kInvalidModel, *problem);
  try {
    out.fs = load(out.kind, model);
  } catch (const ModelRejected&) {
    throw;
  } catch (const nlohmann::json::exception& e) {
    throw ModelRejected(kBadRequest, std::string("model: ") + e.what());
  } catch (const std::exception& e) {
    // models::ConfigError and std::invalid_argument name the key themselves.
    throw ModelRejected(kBadRequest, e.what());
  }
  return out;
}

}  // namespace panelbass::api

#include "models/diagnosis/gray_box_model.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/model_header.h"

namespace panelbass::models {
namespace {

constexpr const char* kGrayBoxKind = "gray_box";

nlohmann::json tf_to_json(const TransferFunction& tf) { return {{"a", to_array(tf.a)}, {"b", to_array(tf.b)}, {"nk", tf.nk}}; }

TransferFunction tf_from_json(const nlohmann::json& j, const std::string& path) {
  JsonFields f(j, path);
  TransferFunction tf;
  const nlohmann::json* a = f.member("a");
  const nlohmann::json* b = f.member("b");
  if (a == nullptr || b == nullptr) throw ConfigError(path + ": needs \"a\" and \"b\"");
  tf.a = read_vector(*a, f.path_of("a"));
  tf.b = read_vector(*b, f.path_of("b"));
  tf.nk = static_cast<int>(f.integer("nk", 0, 0, 100000));
  f.finish();
  return tf;
}

// The value of `names` whose name is `text`; ConfigError naming `path` and the choices otherwise.
template <typename T>
T named(const std::string& text, const std::vector<T>& values, std::string (*name)(T), const std::string& path) {
  std::string choices;
  for (T v : values) {
    if (name(v) == text) return v;
    choices += (choices.empty() ? "" : ", ") + name(v);
  }
  throw ConfigError(path + ": unknown \"" + text + "\" (" + choices + ")");
}

std::string shape_name(Shape s) { return s == Shape::knee ? "knee" : "polynomial"; }
std::string effect_name(Effect e) { return to_string(e); }
std::string proxy_name(StateProxy p) { return to_string(p); }
std::string position_name(Position p) { return to_string(p); }

DiagnosisTerm term_from_json(const nlohmann::json& j, const std::string& path, int lags) {
  JsonFields f(j, path);
  DiagnosisTerm t;
  t.effect = named(f.string("effect", ""), all_effects(), &effect_name, f.path_of("effect"));
  t.proxy = named(f.string("state", "output"),
                  {StateProxy::output, StateProxy::integral, StateProxy::double_integral, StateProxy::input}, &proxy_name,
                  f.path_of("state"));
  t.threshold = f.number("threshold", 0.0);
  t.time_constant_s = f.number("time_constant_s", 0.0);
  require_non_negative(t.time_constant_s, f.path_of("time_constant_s"));
  t.one_sided = f.boolean("one_sided", false);
  t.position = named(f.string("position", "input"), {Position::input, Position::output, Position::between}, &position_name,
                     f.path_of("position"));
  t.shape = named(f.string("shape", "knee"), {Shape::knee, Shape::polynomial}, &shape_name, f.path_of("shape"));
  if (const nlohmann::json* front = f.member("front")) t.front = tf_from_json(*front, f.path_of("front"));
  if (const nlohmann::json* back = f.member("back")) t.back = tf_from_json(*back, f.path_of("back"));
  t.front_rms = f.number("front_rms", 1.0);
  require_positive(t.front_rms, f.path_of("front_rms"));
  const nlohmann::json* c = f.member("coefficients");
  if (c == nullptr) throw ConfigError(f.path_of("coefficients") + ": missing");
  t.coefficients = read_vector(*c, f.path_of("coefficients"));
  f.finish();
  if (t.effect == Effect::static_nonlinearity && (t.front.b.size() == 0 || t.back.b.size() == 0))
    throw ConfigError(path + ": a static_nonlinearity needs its filters \"front\" and \"back\"");
  if ((t.front.b.size() == 0) != (t.back.b.size() == 0))
    throw ConfigError(path + ": \"front\" and \"back\" go together (the filters before and after a static function)");
  const int expected = term_columns(t, lags);
  if (t.coefficients.size() != expected)
    throw ConfigError(f.path_of("coefficients") + ": " + std::to_string(t.coefficients.size()) + " coefficients, " +
                      std::to_string(expected) + " expected for " + to_string(t.effect) + " with " + std::to_string(lags) +
                      " lags");
  return t;
}

}  // namespace

Eigen::VectorXd GrayBoxModel::simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) const {
  return simulate_augmented(augmented, u, y, init);
}

Eigen::VectorXd GrayBoxModel::predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const {
  return augmented.linear.predict(u, y) + simulate_augmented(augmented, u, {}, 0) - augmented.linear.simulate(u);
}

GrayBoxModel gray_box_model_of(const Diagnosis& d) {
  if (d.model.simulate_baseline)
    throw std::invalid_argument("the diagnosed model is a " + d.baseline_kind +
                                " simulation with gray-box terms; only a linear baseline's can be written as a model file");
  GrayBoxModel m;
  m.augmented = d.model;
  m.fs = d.model.linear.fs;
  nlohmann::json findings = nlohmann::json::array();
  for (const Finding& f : d.findings) findings.push_back(to_string(f.effect));
  m.meta = {{"source", "diagnose"},
            {"findings", findings},
            {"J_val_before_pct", d.j_val_before_pct},
            {"J_val_after_pct", d.j_val_after_pct}};
  return m;
}

nlohmann::json term_to_json(const DiagnosisTerm& t) {
  nlohmann::json out = {{"effect", to_string(t.effect)},
                        {"state", to_string(t.proxy)},
                        {"threshold", t.threshold},
                        {"time_constant_s", t.time_constant_s},
                        {"one_sided", t.one_sided},
                        {"position", to_string(t.position)},
                        {"shape", shape_name(t.shape)},
                        {"coefficients", to_array(t.coefficients)}};
  if (has_block_filters(t)) {
    out["front"] = tf_to_json(t.front);
    out["back"] = tf_to_json(t.back);
    out["front_rms"] = t.front_rms;
  }
  return out;
}

nlohmann::json gray_box_model_to_json(const GrayBoxModel& m) {
  nlohmann::json terms = nlohmann::json::array();
  for (const DiagnosisTerm& t : m.augmented.terms) terms.push_back(term_to_json(t));
  return {{"format", kModelFormat},
          {"kind", kGrayBoxKind},
          {"fs", m.fs},
          {"linear", linear_model_to_json(m.augmented.linear)},
          {"terms", terms},
          {"lags", m.augmented.lags},
          {"state_mean", to_array(m.augmented.state_mean)},
          {"state_rms", to_array(m.augmented.state_rms)},
          {"meta", m.meta.is_null() ? nlohmann::json::object() : m.meta}};
}

GrayBoxModel gray_box_model_from_json(const nlohmann::json& j) {
  JsonFields top(j, "model");
  GrayBoxModel m;
  m.fs = read_model_header(top, kGrayBoxKind);
  const nlohmann::json* linear = top.member("linear");
  if (linear == nullptr) throw ConfigError("model.linear: missing (the linear part, a linear model file)");
  try {
    m.augmented.linear = linear_model_from_json(*linear);
  } catch (const ConfigError& e) {
    throw ConfigError(std::string("model.linear: ") + e.what());
  }
  if (std::abs(m.augmented.linear.fs - m.fs) > 1e-9 * m.fs)
    throw ConfigError("model.linear.fs: " + std::to_string(m.augmented.linear.fs) + " Hz, the model's is " + std::to_string(m.fs));
  m.augmented.lags = static_cast<int>(top.integer("lags", 3, 1, 64));
  for (const char* key : {"state_mean", "state_rms"}) {
    const nlohmann::json* v = top.member(key);
    if (v == nullptr) throw ConfigError(top.path_of(key) + ": missing");
    const Eigen::VectorXd x = read_vector(*v, top.path_of(key));
    if (x.size() != 4) throw ConfigError(top.path_of(key) + ": 4 numbers expected, got " + std::to_string(x.size()));
    (std::string(key) == "state_mean" ? m.augmented.state_mean : m.augmented.state_rms) = x;
  }
  for (int k = 0; k < 4; ++k) require_positive(m.augmented.state_rms[k], top.path_of("state_rms") + "[" + std::to_string(k) + "]");
  const nlohmann::json* terms = top.member("terms");
  if (terms == nullptr || !terms->is_array()) throw ConfigError("model.terms: missing (an array of terms)");
  for (std::size_t k = 0; k < terms->size(); ++k)
    m.augmented.terms.push_back(term_from_json((*terms)[k], "model.terms[" + std::to_string(k) + "]", m.augmented.lags));
  m.meta = read_model_meta(top);
  top.finish();
  return m;
}

}  // namespace panelbass::models

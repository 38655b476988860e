#include "models/linear/linear_model.h"

#include "models/io/json_file.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <fstream>
#include <numbers>
#include <stdexcept>

#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/model_header.h"
#include "models/io/number_text.h"
#include "models/linear/stability.h"

namespace panelbass::models {
namespace {

constexpr const char* kKind = "linear";
// An input delay beyond a minute at 384 kHz is a corrupt file, not a model.
constexpr long kMaxDelay = 384000L * 60L;

std::string show(double v) { return number_text(v); }

void require_finite(const Eigen::VectorXd& x, const char* where, const char* name) {
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k])) {
      throw std::invalid_argument(std::string(where) + ": " + name + " is not finite (sample " + std::to_string(k) +
                                  ")");
    }
  }
}

// The loader's stability test (unstable_pole), worded with the pole's frequency so the message points at the mode.
void require_stable(const TransferFunction& tf, double fs) {
  if (const std::optional<UnstablePole> pole = unstable_pole(tf, fs)) {
    throw ConfigError("model: unstable, pole of radius " + show(pole->radius) + " at " + show(pole->hz) + " Hz");
  }
}

}  // namespace

Eigen::VectorXd LinearModel::simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                      Eigen::Index init_samples) const {
  const char* where = "LinearModel::simulate";
  require_finite(u, where, "u");
  if (y.size() != 0 && y.size() != u.size()) {
    throw std::invalid_argument(std::string(where) + ": y has " + std::to_string(y.size()) + " samples, u has " +
                                std::to_string(u.size()));
  }
  if (init_samples < 0 || init_samples > u.size()) {
    throw std::invalid_argument(std::string(where) + ": init_samples = " + std::to_string(init_samples) +
                                " outside [0, " + std::to_string(u.size()) + "]");
  }
  if (init_samples > 0 && y.size() == 0) {
    throw std::invalid_argument(std::string(where) + ": init_samples > 0 needs the measured output y");
  }
  const Eigen::VectorXd us = scaling.scale_u(u);
  // A state-space realisation, never the direct-form recursion: a high-order polynomial recursion
  // amplifies rounding by the sensitivity of its poles to its coefficients.
  const StateSpace ss = realize(tf);
  Eigen::VectorXd x0;
  if (init_samples > 0) {
    require_finite(y.head(init_samples), where, "y");
    x0 = initial_state(ss, us, scaling.scale_y(y), init_samples);
  }
  return scaling.unscale_y(models::simulate(ss, us, x0));
}

Eigen::VectorXd LinearModel::predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const {
  const char* where = "LinearModel::predict";
  if (y.size() != u.size()) {
    throw std::invalid_argument(std::string(where) + ": y has " + std::to_string(y.size()) + " samples, u has " +
                                std::to_string(u.size()));
  }
  require_finite(u, where, "u");
  require_finite(y, where, "y");
  const Eigen::VectorXd us = scaling.scale_u(u);
  const Eigen::VectorXd ys = scaling.scale_y(y);
  Eigen::VectorXd prediction = ys;  // the first `first` samples stay as measured
  const Eigen::Index first = std::max<Eigen::Index>(tf.na(), tf.nk + tf.nb() - 1);
  // [ARX] ŷ(k) = −Σ_{i=1..na} a_i·y(k−i) + Σ_{j=0..nb−1} b_j·u(k−nk−j), in scaled units
  for (Eigen::Index k = first; k < u.size(); ++k) {
    double v = 0.0;
    for (Eigen::Index i = 0; i < tf.na(); ++i) v -= tf.a[i] * ys[k - 1 - i];
    for (Eigen::Index j = 0; j < tf.nb(); ++j) v += tf.b[j] * us[k - tf.nk - j];
    prediction[k] = v;
  }
  return scaling.unscale_y(prediction);
}

nlohmann::json linear_model_to_json(const LinearModel& m) {
  return {
      {"format", kModelFormat},
      {"kind", kKind},
      {"fs", m.fs},
      {"method", m.method},
      {"scaling", scaling_to_json(m.scaling)},
      {"params", {{"a", to_array(m.tf.a)}, {"b", to_array(m.tf.b)}, {"nk", m.tf.nk}}},
      {"meta", m.meta.is_null() ? nlohmann::json::object() : m.meta},
  };
}

LinearModel linear_model_from_json(const nlohmann::json& j) {
  LinearModel m;
  JsonFields top(j, "model");
  m.fs = read_model_header(top, kKind);
  m.method = top.string("method", "");

  m.scaling = read_model_scaling(top);
  JsonFields p(read_model_params(top), "model.params");
  const nlohmann::json* a = p.member("a");
  if (a == nullptr) throw ConfigError("model.params.a: missing");
  m.tf.a = read_vector(*a, "model.params.a");
  const nlohmann::json* b = p.member("b");
  if (b == nullptr) throw ConfigError("model.params.b: missing");
  m.tf.b = read_vector(*b, "model.params.b");
  if (m.tf.b.size() == 0) throw ConfigError("model.params.b: must not be empty");
  m.tf.nk = static_cast<int>(p.integer("nk", 0, 0, kMaxDelay));
  p.finish();

  m.meta = read_model_meta(top);
  top.finish();
  require_stable(m.tf, m.fs);
  return m;
}

void save_linear_model(const std::filesystem::path& path, const LinearModel& m) {
  write_json_file(path, linear_model_to_json(m));
}

LinearModel load_linear_model(const std::filesystem::path& path) {
  return read_json_file_as(path, linear_model_from_json);
}

}  // namespace panelbass::models

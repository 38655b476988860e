#include "models/narx/narx_model.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/model_header.h"
#include "models/io/network_fields.h"
#include "models/narx/free_run.h"
#include "models/narx/narx_history.h"

namespace panelbass::models {
namespace {

constexpr const char* kNarxKind = "narx";
// Network inputs na + nb + 1 beyond this are a corrupt file, not a model.
constexpr long kMaxInputs = 1000;
// An input delay beyond a minute at 384 kHz is a corrupt file, not a model.
constexpr long kMaxDelay = 384000L * 60L;

void require_finite(const Eigen::VectorXd& x, const std::string& where, const char* name) {
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k])) {
      throw std::invalid_argument(where + ": " + name + " is not finite (sample " + std::to_string(k) + ")");
    }
  }
}

void require_same_length(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const std::string& where) {
  if (y.size() != u.size()) {
    throw std::invalid_argument(where + ": y has " + std::to_string(y.size()) + " samples, u has " +
                                std::to_string(u.size()));
  }
}

// The checks shared by simulate and simulate_scaled: y empty or as long as u, init within the record
// and backed by measured samples, and every sample that is read finite.
void check_simulation_args(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init,
                           const std::string& where) {
  require_finite(u, where, "u");
  if (y.size() != 0) require_same_length(u, y, where);
  if (init < 0 || init > u.size()) {
    throw std::invalid_argument(where + ": init = " + std::to_string(init) + " outside [0, " +
                                std::to_string(u.size()) + "]");
  }
  if (init > 0 && y.size() == 0) throw std::invalid_argument(where + ": init > 0 needs the measured output y");
  require_finite(y.head(init), where, "y");
}

void check_network(const NarxModel& m, const std::string& where) {
  if (m.net.inputs() != m.structure.inputs()) {
    throw std::invalid_argument(where + ": the structure has " + std::to_string(m.structure.inputs()) +
                                " network inputs (na + nb + 1), the network " + std::to_string(m.net.inputs()));
  }
}

// A required non-negative integer of `params`.
int read_order(JsonFields& params, const char* key, long hi) {
  if (params.member(key) == nullptr) throw ConfigError(params.path_of(key) + ": missing");
  return static_cast<int>(params.integer(key, 0, 0, hi));
}

// The loader's stability test: a free run on full-scale uniform noise (scaled units) must stay bounded.
void require_bounded_free_run(const NarxModel& m) {
  if (const std::optional<Runaway> run = free_run_runaway(m)) {
    throw ConfigError("model: the free run diverges (|y| > 100 after " + std::to_string(run->samples) + " samples)");
  }
}

}  // namespace

NarxModel NarxModel::with_structure(const NarxStructure& structure, const Scaling& scaling, double fs) {
  if (structure.na < 0 || structure.nb < 0 || structure.nk < 0) {
    throw std::invalid_argument("NarxModel: na, nb and nk must be >= 0, got na = " + std::to_string(structure.na) +
                                ", nb = " + std::to_string(structure.nb) + ", nk = " + std::to_string(structure.nk));
  }
  NarxModel m;
  m.structure = structure;
  m.net = Mlp(structure.inputs(), structure.hidden);
  m.scaling = scaling;
  m.fs = fs;
  return m;
}

void NarxModel::regressor(const Eigen::VectorXd& u, const Eigen::VectorXd& y_past, Eigen::Index k,
                          Eigen::Ref<Eigen::VectorXd> x) const {
  // [5G] from whole records; samples before the record are 0
  fill_narx_regressor(
      structure.na, structure.nb, structure.nk, [&](int i) { return k - 1 - i >= 0 ? y_past[k - 1 - i] : 0.0; },
      [&](int j) { return k - j >= 0 ? u[k - j] : 0.0; }, x);
}

Eigen::VectorXd NarxModel::simulate_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                           Eigen::Index init) const {
  const std::string where = "NarxModel::simulate_scaled";
  check_simulation_args(u, y, init, where);
  check_network(*this, where);
  const Eigen::Index n = u.size();
  Eigen::VectorXd out(n);
  out.head(init) = y.head(init);
  Mlp::Workspace ws = net.workspace();
  Eigen::VectorXd x(structure.inputs());
  // [5H] OEM: ŷ(k) = F(ŷ(k−1..k−na), u(k−nk..k−nk−nb), θ), the simulated output fed back
  for (Eigen::Index k = init; k < n; ++k) {
    regressor(u, out, k, x);
    out[k] = net.forward_unchecked(x, ws);
  }
  return out;
}

Eigen::VectorXd NarxModel::predict_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const {
  const std::string where = "NarxModel::predict_scaled";
  require_same_length(u, y, where);
  require_finite(u, where, "u");
  require_finite(y, where, "y");
  check_network(*this, where);
  const Eigen::Index n = u.size();
  Eigen::VectorXd out(n);
  Mlp::Workspace ws = net.workspace();
  Eigen::VectorXd x(structure.inputs());
  // [5H] PEM: ŷ(k) = F(y(k−1..k−na), u(k−nk..k−nk−nb), θ), the measured output as the past
  for (Eigen::Index k = 0; k < n; ++k) {
    regressor(u, y, k, x);
    out[k] = net.forward_unchecked(x, ws);
  }
  return out;
}

Eigen::VectorXd NarxModel::simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) const {
  check_simulation_args(u, y, init, "NarxModel::simulate");
  const Eigen::VectorXd ys = y.size() != 0 ? scaling.scale_y(y) : Eigen::VectorXd();
  return scaling.unscale_y(simulate_scaled(scaling.scale_u(u), ys, init));
}

Eigen::VectorXd NarxModel::predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const {
  const std::string where = "NarxModel::predict";
  require_same_length(u, y, where);
  require_finite(u, where, "u");
  require_finite(y, where, "y");
  return scaling.unscale_y(predict_scaled(scaling.scale_u(u), scaling.scale_y(y)));
}

Eigen::VectorXd small_signal_response(const NarxModel& m, const Eigen::VectorXd& u) {
  return small_signal_response_of([&m](const Eigen::VectorXd& v) { return m.simulate(v); }, u);
}

Eigen::VectorXd small_signal_response_of(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& simulate,
                                         const Eigen::VectorXd& u) {
  require_finite(u, "small_signal_response", "u");
  const double peak = u.size() != 0 ? u.cwiseAbs().maxCoeff() : 0.0;
  if (peak == 0.0) return Eigen::VectorXd::Zero(u.size());
  const double epsilon = 1e-5 / peak;
  const Eigen::VectorXd up = epsilon * u;
  return (simulate(up) - simulate(-up)) / (2.0 * epsilon);
}

nlohmann::json narx_model_to_json(const NarxModel& m) {
  return {
      {"format", kModelFormat},
      {"kind", kNarxKind},
      {"fs", m.fs},
      {"scaling", scaling_to_json(m.scaling)},
      {"params",
       {{"na", m.structure.na},
        {"nb", m.structure.nb},
        {"nk", m.structure.nk},
        {"hidden", m.structure.hidden},
        {"theta", to_array(m.net.parameters())}}},
      {"meta", m.meta.is_null() ? nlohmann::json::object() : m.meta},
  };
}

NarxModel narx_model_from_json(const nlohmann::json& j) {
  JsonFields top(j, "model");
  const double fs = read_model_header(top, kNarxKind);

  const Scaling scaling = read_model_scaling(top);
  JsonFields p(read_model_params(top), "model.params");
  NarxStructure structure;
  structure.na = read_order(p, "na", kMaxInputs - 1);
  structure.nb = read_order(p, "nb", kMaxInputs - 1);
  structure.nk = read_order(p, "nk", kMaxDelay);
  if (structure.inputs() > kMaxInputs) {
    throw ConfigError("model.params: na + nb + 1 = " + std::to_string(structure.inputs()) + " network inputs, at most " +
                      std::to_string(kMaxInputs));
  }
  structure.hidden = read_hidden(p.member("hidden"), p.path_of("hidden"));
  const std::int64_t count = parameter_count(structure.inputs(), structure.hidden);
  const Eigen::VectorXd theta = read_theta(p.member("theta"), p.path_of("theta"), count);
  p.finish();

  nlohmann::json meta = read_model_meta(top);
  top.finish();

  NarxModel model = NarxModel::with_structure(structure, scaling, fs);
  model.net.parameters() = theta;
  model.meta = std::move(meta);
  require_bounded_free_run(model);
  return model;
}

}  // namespace panelbass::models

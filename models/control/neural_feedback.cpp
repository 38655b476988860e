#include "models/control/neural_feedback.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/soft_limit.h"
#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/model_header.h"
#include "models/io/network_fields.h"

namespace panelbass::models {
namespace {

constexpr const char* kKind = "neural_feedback";
// Orders beyond this are a corrupt file, not a controller.
constexpr long kMaxOrder = 1000;

void require_structure(const FeedbackStructure& s) {
  if (s.nu < 0 || s.nv < 0 || s.ny < 0) {
    throw std::invalid_argument("neural feedback: orders must be >= 0, got nu = " + std::to_string(s.nu) +
                                ", nv = " + std::to_string(s.nv) + ", ny = " + std::to_string(s.ny));
  }
  if (s.hidden.empty()) throw std::invalid_argument("neural feedback: at least one hidden layer is needed");
}

// Shifts `history` one place towards the past and puts `newest` first.
void push_front(std::vector<double>& history, double newest) noexcept {
  if (history.empty()) return;
  std::copy_backward(history.begin(), history.end() - 1, history.end());
  history.front() = newest;
}

}  // namespace

NeuralFeedback NeuralFeedback::with_structure(const FeedbackStructure& structure, const NarxModel& plant) {
  require_structure(structure);
  NeuralFeedback c;
  c.structure = structure;
  c.net = Mlp(structure.inputs(), structure.hidden);
  c.plant = plant;
  c.fs = plant.fs;
  return c;
}

void NeuralFeedback::regressor(const Eigen::VectorXd& u, const Eigen::VectorXd& v, const Eigen::VectorXd& y_scaled,
                               Eigen::Index k, Eigen::Ref<Eigen::VectorXd> r) const {
  const FeedbackStructure& s = structure;
  Eigen::Index i = 0;
  // Appendix 3: r(k) = [u(k..k−nu), v(k−1..k−nv), y(k−1..k−ny)]; samples before the record are 0
  for (Eigen::Index j = 0; j <= s.nu; ++j) r[i++] = k - j >= 0 ? u[k - j] : 0.0;
  for (Eigen::Index j = 1; j <= s.nv; ++j) r[i++] = k - j >= 0 ? v[k - j] : 0.0;
  for (Eigen::Index j = 1; j <= s.ny; ++j) r[i++] = k - j >= 0 ? y_scaled[k - j] : 0.0;
}

ClosedLoopRun simulate_closed_loop(const NeuralFeedback& c, const Eigen::VectorXd& u) {
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    if (!std::isfinite(u[k])) {
      throw std::invalid_argument("simulate_closed_loop: u is not finite (sample " + std::to_string(k) + ")");
    }
  }
  const Eigen::Index n = u.size();
  ClosedLoopRun run{Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n)};
  const Scaling& sc = c.plant.scaling;
  Eigen::VectorXd y_scaled = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd v_scaled = Eigen::VectorXd::Zero(n);
  Mlp::Workspace ws = c.net.workspace();
  Mlp::Workspace plant_ws = c.plant.net.workspace();
  Eigen::VectorXd r(c.structure.inputs());
  Eigen::VectorXd x(c.plant.structure.inputs());
  // fig. 7.10: v(k) = N1(u, past v, past y), then y(k) = N2(past v, past y) ([5G], free run)
  for (Eigen::Index k = 0; k < n; ++k) {
    c.regressor(u, run.v, y_scaled, k, r);
    run.s[k] = u[k] + c.net.forward(r, ws);
    run.v[k] = dsp::soft_limit(run.s[k], c.knee);
    v_scaled[k] = (run.v[k] - sc.u_offset) / sc.u_scale;
    c.plant.regressor(v_scaled, y_scaled, k, x);
    y_scaled[k] = c.plant.net.forward(x, plant_ws);
  }
  run.y = sc.unscale_y(y_scaled);
  return run;
}

FeedbackRunner::FeedbackRunner(const NeuralFeedback& controller) : c_(controller) {
  const FeedbackStructure& s = c_.structure;
  const NarxStructure& p = c_.plant.structure;
  if (c_.net.inputs() != s.inputs()) {
    throw std::invalid_argument("neural feedback: the structure has " + std::to_string(s.inputs()) +
                                " network inputs, the network " + std::to_string(c_.net.inputs()));
  }
  ws_ = c_.net.workspace();
  plant_ws_ = c_.plant.net.workspace();
  r_ = Eigen::VectorXd::Zero(s.inputs());
  x_ = Eigen::VectorXd::Zero(p.inputs());
  u_hist_.assign(static_cast<std::size_t>(s.nu + 1), 0.0);
  v_hist_.assign(static_cast<std::size_t>(s.nv), 0.0);
  y_hist_.assign(static_cast<std::size_t>(s.ny), 0.0);
  plant_u_hist_.assign(static_cast<std::size_t>(p.nk + p.nb + 1), 0.0);
  plant_y_hist_.assign(static_cast<std::size_t>(p.na), 0.0);
}

double FeedbackRunner::control(double u) noexcept {
  push_front(u_hist_, u);
  Eigen::Index i = 0;
  for (double x : u_hist_) r_[i++] = x;
  for (double x : v_hist_) r_[i++] = x;
  for (double x : y_hist_) r_[i++] = x;
  const double v = dsp::soft_limit(u + c_.net.forward(r_, ws_), c_.knee);
  push_front(v_hist_, v);
  const Scaling& sc = c_.plant.scaling;
  push_front(plant_u_hist_, (v - sc.u_offset) / sc.u_scale);
  return v;
}

double FeedbackRunner::plant_model_output() noexcept {
  const NarxStructure& p = c_.plant.structure;
  Eigen::Index i = 0;
  for (double y : plant_y_hist_) x_[i++] = y;
  for (int j = 0; j <= p.nb; ++j) x_[i++] = plant_u_hist_[static_cast<std::size_t>(p.nk + j)];
  const double y_scaled = c_.plant.net.forward(x_, plant_ws_);
  push_front(plant_y_hist_, y_scaled);
  const Scaling& sc = c_.plant.scaling;
  return y_scaled * sc.y_scale + sc.y_offset;
}

void FeedbackRunner::push_output(double y) noexcept {
  const Scaling& sc = c_.plant.scaling;
  push_front(y_hist_, (y - sc.y_offset) / sc.y_scale);
}

void FeedbackRunner::reset() noexcept {
  for (auto* h : {&u_hist_, &v_hist_, &y_hist_, &plant_u_hist_, &plant_y_hist_}) std::fill(h->begin(), h->end(), 0.0);
}

nlohmann::json neural_feedback_to_json(const NeuralFeedback& c) {
  return {
      {"format", kModelFormat},
      {"kind", kKind},
      {"fs", c.fs},
      {"params",
       {{"nu", c.structure.nu},
        {"nv", c.structure.nv},
        {"ny", c.structure.ny},
        {"hidden", c.structure.hidden},
        {"knee", c.knee},
        {"theta", to_array(c.net.parameters())}}},
      {"plant", narx_model_to_json(c.plant)},
      {"meta", c.meta.is_null() ? nlohmann::json::object() : c.meta},
  };
}

NeuralFeedback neural_feedback_from_json(const nlohmann::json& j) {
  JsonFields top(j, "model");
  const double fs = read_model_header(top, kKind);

  const nlohmann::json* params = top.member("params");
  if (params == nullptr) throw ConfigError("model.params: missing");
  JsonFields p(*params, "model.params");
  FeedbackStructure s;
  for (auto [key, field] : {std::pair{"nu", &s.nu}, std::pair{"nv", &s.nv}, std::pair{"ny", &s.ny}}) {
    if (p.member(key) == nullptr) throw ConfigError(p.path_of(key) + ": missing");
    *field = static_cast<int>(p.integer(key, 0, 0, kMaxOrder));
  }
  s.hidden = read_hidden(p.member("hidden"), p.path_of("hidden"));
  const double knee = p.number("knee", 0.8);
  if (!(knee >= 0.0 && knee < 1.0)) {
    throw ConfigError("model.params.knee: must be within [0, 1), got " + std::to_string(knee));
  }
  const Eigen::VectorXd theta = read_theta(p.member("theta"), p.path_of("theta"), parameter_count(s.inputs(), s.hidden));
  p.finish();

  const nlohmann::json* plant_json = top.member("plant");
  if (plant_json == nullptr) throw ConfigError("model.plant: missing");
  NarxModel plant;
  try {
    plant = narx_model_from_json(*plant_json);
  } catch (const ConfigError& e) {
    // "model.x: …" of the plant's own loader becomes "model.plant.x: …"
    const std::string what = e.what();
    throw ConfigError(what.rfind("model", 0) == 0 ? "model.plant" + what.substr(5) : "model.plant: " + what);
  }
  if (std::abs(plant.fs - fs) > 1e-9 * fs) {
    throw ConfigError("model.plant.fs: " + std::to_string(plant.fs) + " Hz, the controller runs at " +
                      std::to_string(fs) + " Hz");
  }
  nlohmann::json meta = read_model_meta(top);
  top.finish();

  NeuralFeedback c = NeuralFeedback::with_structure(s, plant);
  c.net.parameters() = theta;
  c.knee = knee;
  c.fs = fs;
  c.meta = std::move(meta);
  return c;
}

}  // namespace panelbass::models

#include "models/control/neural_feedback.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/sample_rate.h"
#include "dsp/soft_limit.h"
#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/model_header.h"
#include "models/io/network_fields.h"

namespace panelbass::models {
namespace {

constexpr const char* kNeuralFeedbackKind = "neural_feedback";
// Orders beyond this are a corrupt file, not a controller.
constexpr long kMaxOrder = 1000;

void require_structure(const FeedbackStructure& s) {
  if (s.nu < 0 || s.nv < 0 || s.ny < 0) {
    throw std::invalid_argument("neural feedback: orders must be >= 0, got nu = " + std::to_string(s.nu) +
                                ", nv = " + std::to_string(s.nv) + ", ny = " + std::to_string(s.ny));
  }
  if (s.hidden.empty()) throw std::invalid_argument("neural feedback: at least one hidden layer is needed");
}

}  // namespace

NeuralFeedback NeuralFeedback::with_structure(const FeedbackStructure& structure, const LoopPlant& plant) {
  require_structure(structure);
  NeuralFeedback c;
  c.structure = structure;
  c.net = Mlp(structure.inputs(), structure.hidden);
  c.plant = plant;
  c.fs = plant.fs();
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
  const Scaling& sc = c.plant.scaling();
  Eigen::VectorXd y_scaled = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd v_scaled = Eigen::VectorXd::Zero(n);
  Mlp::Workspace ws = c.net.workspace();
  LoopPlantSweep plant(c.plant, c.net.parameter_count());
  plant.start();
  Eigen::VectorXd r(c.structure.inputs());
  // fig. 7.10: v(k) = N1(u, past v, past y), then y(k) from the drives (the plant model's free run)
  for (Eigen::Index k = 0; k < n; ++k) {
    c.regressor(u, run.v, y_scaled, k, r);
    run.s[k] = u[k] + c.net.forward(r, ws);
    run.v[k] = dsp::soft_limit(run.s[k], c.knee);
    v_scaled[k] = (run.v[k] - sc.u_offset) / sc.u_scale;
    y_scaled[k] = plant.step(k, v_scaled, y_scaled);
  }
  run.y = sc.unscale_y(y_scaled);
  return run;
}

FeedbackRunner::FeedbackRunner(const NeuralFeedback& controller) : c_(controller) {
  const FeedbackStructure& s = c_.structure;
  if (c_.net.inputs() != s.inputs()) {
    throw std::invalid_argument("neural feedback: the structure has " + std::to_string(s.inputs()) +
                                " network inputs, the network " + std::to_string(c_.net.inputs()));
  }
  plant_ = LoopPlantRunner(c_.plant);
  ws_ = c_.net.workspace();
  r_ = Eigen::VectorXd::Zero(s.inputs());
  u_hist_ = SignalHistory(static_cast<std::size_t>(s.nu + 1));
  v_hist_ = SignalHistory(static_cast<std::size_t>(s.nv));
  y_hist_ = SignalHistory(static_cast<std::size_t>(s.ny));
}

double FeedbackRunner::control(double u) noexcept {
  u_hist_.push(u);
  // Appendix 3: r(k) = [u(k..k−nu), v(k−1..k−nv), y(k−1..k−ny)]
  u_hist_.copy_to(r_, 0);
  v_hist_.copy_to(r_, static_cast<Eigen::Index>(u_hist_.size()));
  y_hist_.copy_to(r_, static_cast<Eigen::Index>(u_hist_.size() + v_hist_.size()));
  asked_ = u + c_.net.forward_unchecked(r_, ws_);
  const double v = dsp::soft_limit(asked_, c_.knee);
  v_hist_.push(v);
  const Scaling& sc = c_.plant.scaling();
  plant_.push_input((v - sc.u_offset) / sc.u_scale);
  return v;
}

double FeedbackRunner::plant_model_output() noexcept {
  const double y_scaled = plant_.output();
  const Scaling& sc = c_.plant.scaling();
  return y_scaled * sc.y_scale + sc.y_offset;
}

void FeedbackRunner::push_output(double y) noexcept {
  const Scaling& sc = c_.plant.scaling();
  y_hist_.push((y - sc.y_offset) / sc.y_scale);
}

void FeedbackRunner::reset() noexcept {
  u_hist_.reset();
  v_hist_.reset();
  y_hist_.reset();
  plant_.reset();
  asked_ = 0.0;
}

nlohmann::json neural_feedback_to_json(const NeuralFeedback& c) {
  return {
      {"format", kModelFormat},
      {"kind", kNeuralFeedbackKind},
      {"fs", c.fs},
      {"params",
       {{"nu", c.structure.nu},
        {"nv", c.structure.nv},
        {"ny", c.structure.ny},
        {"hidden", c.structure.hidden},
        {"knee", c.knee},
        {"theta", to_array(c.net.parameters())}}},
      {"plant", loop_plant_to_json(c.plant)},
      {"meta", c.meta.is_null() ? nlohmann::json::object() : c.meta},
  };
}

NeuralFeedback neural_feedback_from_json(const nlohmann::json& j) {
  JsonFields top(j, "model");
  const double fs = read_model_header(top, kNeuralFeedbackKind);

  JsonFields p(read_model_params(top), "model.params");
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
  LoopPlant plant;
  try {
    plant = loop_plant_from_json(*plant_json);
  } catch (const ConfigError& e) {
    // "model.x: …" of the plant's own loader becomes "model.plant.x: …"
    const std::string what = e.what();
    throw ConfigError(what.rfind("model", 0) == 0 ? "model.plant" + what.substr(5) : "model.plant: " + what);
  }
  if (!dsp::same_rate(plant.fs(), fs)) {
    throw ConfigError("model.plant.fs: " + std::to_string(plant.fs()) + " Hz, the controller runs at " +
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

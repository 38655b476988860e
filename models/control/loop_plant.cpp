#include "models/control/loop_plant.h"

#include <stdexcept>
#include <string>

#include "models/io/config_error.h"

namespace panelbass::models {
namespace {

// The encoder's state for a silent history (z = 0): where the loop starts (the header says why).
Eigen::MatrixXd rest_state(const SsModel& m) {
  const auto p = ss_parts(m.structure, m.theta.data());
  const Eigen::MatrixXd z = Eigen::MatrixXd::Zero(2 * m.structure.lags, 1);
  Eigen::MatrixXd hidden, x0(m.structure.states, 1);
  ss_encode(p, z, hidden, x0);
  return x0;
}

}  // namespace

const char* LoopPlant::kind() const { return std::holds_alternative<NarxModel>(model) ? "narx" : "ss"; }

double LoopPlant::fs() const {
  return std::visit([](const auto& m) { return m.fs; }, model);
}

const Scaling& LoopPlant::scaling() const {
  return std::visit([](const auto& m) -> const Scaling& { return m.scaling; }, model);
}

Eigen::VectorXd LoopPlant::simulate(const Eigen::VectorXd& u) const {
  return std::visit([&u](const auto& m) { return m.simulate(u); }, model);
}

Eigen::VectorXd LoopPlant::small_signal_response(const Eigen::VectorXd& u) const {
  if (const auto* narx = std::get_if<NarxModel>(&model)) return models::small_signal_response(*narx, u);
  const auto& ss = std::get<SsModel>(model);
  return small_signal_response_of([&ss](const Eigen::VectorXd& v) { return ss.simulate(v); }, u);
}

void LoopPlant::check() const {
  if (const auto* narx = std::get_if<NarxModel>(&model)) {
    if (narx->net.inputs() != narx->structure.inputs()) {
      throw std::invalid_argument("neural feedback: the plant model's structure has " +
                                  std::to_string(narx->structure.inputs()) +
                                  " network inputs (na + nb + 1), its network " + std::to_string(narx->net.inputs()));
    }
    return;
  }
  const auto& ss = std::get<SsModel>(model);
  ss.structure.check();
  if (ss.theta.size() != ss.structure.parameter_count()) {
    throw std::invalid_argument("neural feedback: the ss plant model's sizes need " +
                                std::to_string(ss.structure.parameter_count()) + " parameters, it has " +
                                std::to_string(ss.theta.size()));
  }
}

nlohmann::json loop_plant_to_json(const LoopPlant& p) {
  if (const auto* narx = std::get_if<NarxModel>(&p.model)) return narx_model_to_json(*narx);
  return ss_model_to_json(std::get<SsModel>(p.model));
}

LoopPlant loop_plant_from_json(const nlohmann::json& j) {
  if (!j.is_object()) throw ConfigError("model: expected a model file object (NARX or state-space)");
  const auto kind = j.find("kind");
  if (kind == j.end()) throw ConfigError("model.kind: missing");
  if (*kind == "narx") return narx_model_from_json(j);
  if (*kind == "ss") return ss_model_from_json(j);
  throw ConfigError("model.kind: expected \"narx\" or \"ss\" (a plant model), got " + kind->dump());
}

LoopPlantSweep::LoopPlantSweep(const LoopPlant& plant, Eigen::Index parameters) : plant_(plant) {
  if (const auto* narx = std::get_if<NarxModel>(&plant_.model)) {
    ws_ = narx->net.workspace();
    x_.resize(narx->structure.inputs());
    dx_.resize(narx->structure.inputs());
    dtheta_.resize(narx->net.parameter_count());
  } else {
    const Eigen::Index n = std::get<SsModel>(plant_.model).structure.states;
    Dx_.resize(parameters, n);
    Dx_next_.resize(parameters, n);
    next_.resize(n, 1);
    drive_.resize(1);
    output_.resize(1);
  }
}

void LoopPlantSweep::start() {
  if (const auto* ss = std::get_if<SsModel>(&plant_.model)) {
    state_ = rest_state(*ss);
    fresh_ = true;
    Dx_.setZero();
  }
}

double LoopPlantSweep::step(Eigen::Index k, const Eigen::VectorXd& v_scaled, const Eigen::VectorXd& y_scaled) {
  if (const auto* narx = std::get_if<NarxModel>(&plant_.model)) {
    // [5G] ŷ(k) = N2(ŷ(k−1..k−na), v(k−nk..k−nk−nb))
    narx->regressor(v_scaled, y_scaled, k, x_);
    return narx->net.forward(x_, ws_);
  }
  const auto& ss = std::get<SsModel>(plant_.model);
  // ŷ(k) = C·x(k) + D·v(k) + h(x(k), v(k)),  x(k+1) = A·x(k) + B·v(k) + f(x(k), v(k))
  if (!fresh_) state_.swap(next_);  // x(k) is the last step's next state
  fresh_ = false;
  drive_(0) = v_scaled[k];
  ss_step(ss_parts(ss.structure, ss.theta.data()), state_, drive_, work_, output_, next_);
  return output_(0);
}

void LoopPlantSweep::sensitivities(Eigen::Index k, const Eigen::MatrixXd& Dv, Eigen::MatrixXd& Dy) {
  const double u_scale = plant_.scaling().u_scale;
  auto dy = Dy.col(k);
  if (const auto* narx = std::get_if<NarxModel>(&plant_.model)) {
    const NarxStructure& ps = narx->structure;
    narx->net.backward(ws_, dtheta_, dx_);
    // Appendix 3 [1]: dy/dθ1 = ∂N2/∂y·W(z⁻¹)·dy/dθ1 + ∂N2/∂v·dv/dθ1 (the closed-loop form of [5L])
    for (Eigen::Index i = 1; i <= ps.na && k - i >= 0; ++i) dy.noalias() += dx_[i - 1] * Dy.col(k - i);
    for (Eigen::Index j = 0; j <= ps.nb && k - ps.nk - j >= 0; ++j) {
      dy.noalias() += (dx_[ps.na + j] / u_scale) * Dv.col(k - ps.nk - j);
    }
    return;
  }
  const auto& ss = std::get<SsModel>(plant_.model);
  const auto p = ss_parts(ss.structure, ss.theta.data());
  const Eigen::Index n = ss.structure.states;
  ss_network_jacobian(p, state_.col(0), drive_(0), work_.factors, jacobian_);
  // dŷ(k)/dθ1 = dx(k)/dθ1·(C + ∂h/∂x)ᵀ + (D + ∂h/∂v)·dv(k)/dθ1,
  // dx(k+1)/dθ1 = dx(k)/dθ1·(A + ∂f/∂x)ᵀ + dv(k)/dθ1·(B + ∂f/∂v)ᵀ (dv in scaled units: / u_scale)
  const Eigen::RowVectorXd dy_dx = p.C.row(0) + jacobian_.row(n).head(n);
  const double dy_dv = (p.D(0, 0) + jacobian_(n, n)) / u_scale;
  dy.noalias() += Dx_ * dy_dx.transpose();
  dy.noalias() += dy_dv * Dv.col(k);
  const Eigen::MatrixXd dx_dx = p.A + jacobian_.topLeftCorner(n, n);
  const Eigen::VectorXd dx_dv = (p.B.col(0) + jacobian_.col(n).head(n)) / u_scale;
  Dx_next_.noalias() = Dx_ * dx_dx.transpose();
  Dx_next_.noalias() += Dv.col(k) * dx_dv.transpose();
  Dx_.swap(Dx_next_);
}

LoopPlantRunner::LoopPlantRunner(const LoopPlant& plant) : plant_(&plant) {
  plant.check();
  if (const auto* narx = std::get_if<NarxModel>(&plant.model)) {
    ws_ = narx->net.workspace();
    history_ = NarxHistory(narx->structure);
    return;
  }
  const auto& ss = std::get<SsModel>(plant.model);
  rest_ = rest_state(ss);
  state_ = rest_;
  next_ = rest_;
  drive_ = Eigen::RowVectorXd::Zero(1);
  output_ = Eigen::RowVectorXd::Zero(1);
  // one step sizes the step's workspace (and ζ's monomial list), so that output() never allocates
  ss_step(ss_parts(ss.structure, ss.theta.data()), state_, drive_, work_, output_, next_);
  reset();
}

void LoopPlantRunner::push_input(double v_scaled) noexcept {
  if (plant_ == nullptr) return;
  if (std::holds_alternative<NarxModel>(plant_->model)) {
    history_.push_input(v_scaled);
  } else {
    drive_(0) = v_scaled;
  }
}

double LoopPlantRunner::output() noexcept {
  if (plant_ == nullptr) return 0.0;
  if (const auto* narx = std::get_if<NarxModel>(&plant_->model)) {
    const double y_scaled = narx->net.forward_unchecked(history_.regressor(), ws_);
    history_.push_output(y_scaled);
    return y_scaled;
  }
  const auto& ss = std::get<SsModel>(plant_->model);
  ss_step(ss_parts(ss.structure, ss.theta.data()), state_, drive_, work_, output_, next_);
  state_.swap(next_);
  return output_(0);
}

void LoopPlantRunner::reset() noexcept {
  history_.reset();
  if (state_.size() > 0) {
    state_ = rest_;
    drive_(0) = 0.0;
  }
}

}  // namespace panelbass::models

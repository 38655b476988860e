// Multiple shooting for the neural state-space model. Choices beyond the header:
// - The windows tile the estimation data from sample `lags` on (the encoder reads the lags before each); the
//   samples after the last whole window are left out, as polish_ss leaves them.
// - The loss is ss_window_loss_from_states's with the continuity penalty as its final-state term, plus the
//   encoder's term, whose gradient into the encoder is ss_add_encoder_gradient's.
// - The L-BFGS run, its runaway trials and the selection are ss_lbfgs's, polish_ss's own.
#include "models/state_space_nn/ss_multiple_shooting.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace panelbass::models {

double ss_shooting_loss(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, const SsWindows& windows,
                        const Eigen::MatrixXd& x0, double penalty, Eigen::VectorXd* gradient,
                        Eigen::MatrixXd* state_gradient) {
  if (!(penalty >= 0.0) || !std::isfinite(penalty)) {
    throw std::invalid_argument("ss_shooting_loss: the penalty must be a finite number >= 0, got " + std::to_string(penalty));
  }
  const Eigen::Index T = windows.length, W = static_cast<Eigen::Index>(windows.starts.size());
  for (Eigen::Index w = 1; w < W; ++w) {
    if (windows.starts[static_cast<std::size_t>(w)] != windows.starts[static_cast<std::size_t>(w - 1)] + T) {
      throw std::invalid_argument("ss_shooting_loss: window " + std::to_string(w) + " does not start where window " +
                                  std::to_string(w - 1) + " ends");
    }
  }
  const double weight = penalty / static_cast<double>(W * T);  // ρ over the loss's W·T
  // ρ·Σ_{w≥1} ‖x0_w − x_{w−1}(T)‖²: gradient −2ρ·gap on window w−1's final state, +2ρ·gap on x0_w
  Eigen::MatrixXd gap;
  const SsFinalStateTerm continuity = [&](const Eigen::MatrixXd& final_states, Eigen::MatrixXd& final_gradient) {
    gap = x0.rightCols(W - 1) - final_states.leftCols(W - 1);
    final_gradient.leftCols(W - 1) = -2.0 * weight * gap;
    return weight * gap.squaredNorm();
  };
  Eigen::MatrixXd dx0;
  double loss = ss_window_loss_from_states(m, u, y, windows, x0, continuity, gradient, &dx0);
  // ρ·Σ_w ‖encoder(z_w) − x0_w‖²
  const Eigen::MatrixXd encoder_gap = ss_encoded_states(m, u, y, windows) - x0;
  loss += weight * encoder_gap.squaredNorm();
  if (gradient == nullptr) return loss;
  dx0.rightCols(W - 1) += 2.0 * weight * gap;
  dx0 -= 2.0 * weight * encoder_gap;
  ss_add_encoder_gradient(m, u, y, windows, 2.0 * weight * encoder_gap, *gradient);
  if (state_gradient != nullptr) *state_gradient = std::move(dx0);
  return loss;
}

SsTraining train_ss_shooting(const SsModel& start, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                             const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, const SsShootingOptions& options) {
  if (u.size() != y.size() || u_val.size() != y_val.size()) {
    throw std::invalid_argument("train_ss_shooting: input and output lengths differ");
  }
  const Eigen::Index L = start.structure.lags, T = options.window;
  if (T < 1 || u.size() < L + 2 * T) {
    throw std::invalid_argument("train_ss_shooting: " + std::to_string(u.size()) +
                                " estimation samples, at least lags + 2 windows = " + std::to_string(L + 2 * T) + " needed");
  }
  if (!(options.penalty >= 0.0) || !std::isfinite(options.penalty) || options.iterations < 1) {
    throw std::invalid_argument("train_ss_shooting: the penalty must be a finite number >= 0 and the iterations >= 1");
  }
  const bool has_val = u_val.size() != 0;
  if (options.init >= (has_val ? u_val : u).size()) {
    throw std::invalid_argument("train_ss_shooting: init is not shorter than the selection data");
  }
  const Eigen::VectorXd us = start.scaling.scale_u(u), ys = start.scaling.scale_y(y);
  std::vector<Eigen::Index> starts;
  for (Eigen::Index k0 = L; k0 + T <= u.size(); k0 += T) starts.push_back(k0);
  const SsWindows windows{starts, T};
  const Eigen::Index P = start.theta.size(), n = start.structure.states, W = static_cast<Eigen::Index>(starts.size());
  // z = [θ; vec(x0)], the free states starting where the encoder reads them
  Eigen::VectorXd z0(P + n * W);
  z0 << start.theta, ss_encoded_states(start, us, ys, windows).reshaped();
  SsModel model = start;
  Eigen::VectorXd theta_gradient;
  Eigen::MatrixXd state_gradient;
  const SsStackedLoss loss = [&](const Eigen::VectorXd& z, Eigen::VectorXd* gradient) {
    model.theta = z.head(P);
    const Eigen::MatrixXd x0 = z.tail(n * W).reshaped(n, W);
    if (gradient == nullptr) return ss_shooting_loss(model, us, ys, windows, x0, options.penalty, nullptr, nullptr);
    const double V = ss_shooting_loss(model, us, ys, windows, x0, options.penalty, &theta_gradient, &state_gradient);
    gradient->resize(z.size());
    *gradient << theta_gradient, state_gradient.reshaped();
    return V;
  };
  return ss_lbfgs(start, z0, loss, has_val ? u_val : u, has_val ? y_val : y, options.init, options.iterations,
                  options.progress);
}

}  // namespace panelbass::models

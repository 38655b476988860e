// Multiple shooting for the neural state-space model. Choices beyond the header:
// - The windows tile the estimation data from sample `lags` on (the encoder reads the lags before each); the
//   samples after the last whole window are left out, as polish_ss leaves them.
// - The loss is ss_window_loss_from_states's with the continuity penalty as its final-state term, plus the
//   encoder's term, whose gradient into the encoder is ss_add_encoder_gradient's.
// - A trial step so long that a window runs away gets a finite loss far above the start's and a zero
//   gradient, as in polish_ss, so that More–Thuente shortens the step.
#include "models/state_space_nn/ss_multiple_shooting.h"

#include <lbfgs.h>

#include <chrono>
#include <cmath>
#include <new>
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

namespace {

// What liblbfgs's C callbacks reach through their `instance` pointer: z = [θ; vec(x0)].
struct ShootingRun {
  SsModel model;
  const Eigen::VectorXd *us, *ys, *u_sel, *y_sel;
  std::vector<Eigen::Index> starts;
  const SsShootingOptions* options;
  SsTraining* out;
  std::chrono::steady_clock::time_point began;
  Eigen::VectorXd gradient;
  Eigen::MatrixXd x0, state_gradient;
  double start_loss = 0.0;

  /// θ and the initial states from z.
  void unpack(const lbfgsfloatval_t* z, int n) {
    const Eigen::Index P = model.theta.size();
    model.theta = Eigen::Map<const Eigen::VectorXd>(z, P);
    x0 = Eigen::Map<const Eigen::MatrixXd>(z + P, x0.rows(), (n - P) / x0.rows());
  }
};

lbfgsfloatval_t shooting_evaluate(void* instance, const lbfgsfloatval_t* z, lbfgsfloatval_t* g, int n, lbfgsfloatval_t) {
  auto& run = *static_cast<ShootingRun*>(instance);
  run.unpack(z, n);
  const Eigen::Index P = run.model.theta.size();
  const double loss = ss_shooting_loss(run.model, *run.us, *run.ys, {run.starts, run.options->window}, run.x0,
                                       run.options->penalty, &run.gradient, &run.state_gradient);
  if (!std::isfinite(loss) || !run.gradient.allFinite() || !run.state_gradient.allFinite()) {
    Eigen::Map<Eigen::VectorXd>(g, n).setZero();  // a window run away: shorten the step (polish_ss's rule)
    return 1e6 * (run.start_loss + 1.0);
  }
  Eigen::Map<Eigen::VectorXd>(g, P) = run.gradient;
  Eigen::Map<Eigen::MatrixXd>(g + P, run.x0.rows(), run.x0.cols()) = run.state_gradient;
  return loss;
}

int shooting_progress(void* instance, const lbfgsfloatval_t* z, const lbfgsfloatval_t*, lbfgsfloatval_t fx,
                      lbfgsfloatval_t, lbfgsfloatval_t, lbfgsfloatval_t, int n, int k, int) {
  auto& run = *static_cast<ShootingRun*>(instance);
  run.unpack(z, n);
  const double j = ss_selection_j(run.model, *run.u_sel, *run.y_sel, run.options->init);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - run.began).count();
  run.out->history.push_back({k, fx, j, seconds});
  ss_keep_if_better(run.model, j, k, *run.out);
  return run.options->progress && !run.options->progress(run.out->history.back()) ? 1 : 0;
}

}  // namespace

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
  if (!(options.penalty >= 0.0) || !std::isfinite(options.penalty) || options.iterations < 0) {
    throw std::invalid_argument("train_ss_shooting: the penalty must be a finite number >= 0 and the iterations >= 0");
  }
  const bool has_val = u_val.size() != 0;
  if (options.init >= (has_val ? u_val : u).size()) {
    throw std::invalid_argument("train_ss_shooting: init is not shorter than the selection data");
  }
  const Eigen::VectorXd us = start.scaling.scale_u(u), ys = start.scaling.scale_y(y);
  SsTraining out;
  out.model = start;
  ShootingRun run{start, &us, &ys, has_val ? &u_val : &u, has_val ? &y_val : &y, {}, &options, &out,
                  std::chrono::steady_clock::now(), {}, {}, {}, 0.0};
  for (Eigen::Index k0 = L; k0 + T <= u.size(); k0 += T) run.starts.push_back(k0);
  const SsWindows windows{run.starts, T};
  run.x0 = ss_encoded_states(start, us, ys, windows);  // the free states start where the encoder reads them
  out.j_val_pct = ss_selection_j(start, *run.u_sel, *run.y_sel, options.init);
  out.runaway = ss_free_run_runaway(start);
  run.start_loss = ss_shooting_loss(start, us, ys, windows, run.x0, options.penalty, nullptr, nullptr);
  out.history.push_back({0, run.start_loss, out.j_val_pct, 0.0});
  if (options.progress && !options.progress(out.history.back())) return out;
  if (options.iterations == 0) return out;

  const Eigen::Index P = start.theta.size();
  const int n = static_cast<int>(P + run.x0.size());
  lbfgsfloatval_t* z = lbfgs_malloc(n);
  if (z == nullptr) throw std::bad_alloc();
  Eigen::Map<Eigen::VectorXd>(z, P) = start.theta;
  Eigen::Map<Eigen::MatrixXd>(z + P, run.x0.rows(), run.x0.cols()) = run.x0;
  lbfgs_parameter_t param;
  lbfgs_parameter_init(&param);
  param.max_iterations = options.iterations;
  param.epsilon = 0.0;  // no gradient-norm stop: the iterations and the selection J decide
  param.delta = 0.0;
  if (start.structure.poly_degree > 0 || start.structure.activation == SsActivation::cubic) {
    param.linesearch = LBFGS_LINESEARCH_BACKTRACKING_WOLFE;  // as polish_ss: a long step runs a cubic away
  }
  lbfgsfloatval_t fx = 0.0;
  out.status = lbfgs(n, z, &fx, shooting_evaluate, shooting_progress, &run, &param);  // any iterate kept
  lbfgs_free(z);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - run.began).count();
  return out;
}

}  // namespace panelbass::models

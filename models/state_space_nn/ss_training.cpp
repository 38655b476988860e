#include "models/state_space_nn/ss_training.h"

#include <Eigen/Cholesky>
#include <lbfgs.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <chrono>
#include <random>
#include <stdexcept>
#include <string>

#include "models/linear/state_space_runner.h"
#include "models/state_space_nn/ss_gradients.h"
#include "models/validation/performance.h"

namespace panelbass::models {

double ss_selection_j(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) {
  const Eigen::VectorXd simulated = m.simulate(u, y, init);
  if (!simulated.allFinite()) return std::numeric_limits<double>::infinity();
  return j_percent(simulated, y, init);
}

bool ss_keep_if_better(const SsModel& m, double j, int iteration, SsTraining& out) {
  // a finite J below the kept one's (any finite J while the kept one runs away), and a bounded free run —
  // tested only then, as it costs a run
  if (!std::isfinite(j) || !(j < out.j_val_pct || out.runaway) || ss_free_run_runaway(m)) return false;
  out.j_val_pct = j;
  out.model = m;
  out.runaway.reset();
  out.best_epoch = iteration;
  return true;
}

void ss_fit_encoder(SsModel& m, const Eigen::VectorXd& us, const Eigen::VectorXd& ys, const Eigen::MatrixXd& states) {
  const Eigen::Index n = m.structure.states, L = m.structure.lags, samples = us.size();
  if (ys.size() != samples || states.rows() != n || states.cols() != samples || samples <= 3 * L) {
    throw std::invalid_argument("ss_fit_encoder: " + std::to_string(samples) + " samples of input, output and " +
                                std::to_string(n) + " states needed, more than 3 × " + std::to_string(L) + " lags");
  }
  auto p = ss_parts(m.structure, m.theta.data());
  // Least squares of x(k) on [z(k); 1] past the start-up (at most 20000 rows, evenly spread).
  const Eigen::Index first = 2 * L, rows = std::min<Eigen::Index>(20000, samples - first);
  const Eigen::Index stride = std::max<Eigen::Index>(1, (samples - first) / rows);
  Eigen::MatrixXd Z(2 * L + 1, rows), X(n, rows);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const Eigen::Index k = first + r * stride;
    ss_regressor(us, ys, k, static_cast<int>(L), Z.col(r).head(2 * L));
    Z(2 * L, r) = 1.0;
    X.col(r) = states.col(k);
  }
  Eigen::MatrixXd gram = Z * Z.transpose();
  gram.diagonal().array() += 1e-9 * gram.diagonal().mean();
  const Eigen::MatrixXd map = gram.ldlt().solve(Z * X.transpose()).transpose();  // n × (2L + 1)
  p.E = map.leftCols(2 * L);
  p.c2.col(0) = map.col(2 * L);
}

SsModel ss_initial_model(const LinearModel& linear, SsStructure structure, const Eigen::VectorXd& u,
                         const Eigen::VectorXd& y, std::uint64_t seed) {
  if (u.size() != y.size()) throw std::invalid_argument("ss_initial_model: input and output lengths differ");
  StateSpace ss = realize(linear.tf);
  const Eigen::Index n = ss.order(), L = structure.lags, samples = u.size();
  if (samples <= L + 2 * L) {
    throw std::invalid_argument("ss_initial_model: " + std::to_string(samples) + " samples are too few for " +
                                std::to_string(L) + " encoder lags");
  }
  const Eigen::VectorXd us = linear.scaling.scale_u(u), ys = linear.scaling.scale_y(y);
  // The linear model's state along the data, from rest.
  Eigen::MatrixXd states(n, samples);
  StateSpaceRunner runner(ss);
  for (Eigen::Index k = 0; k < samples; ++k) {
    states.col(k) = runner.state();
    runner.step(us(k));
  }
  Eigen::VectorXd scale(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double rms = std::sqrt(states.row(i).squaredNorm() / static_cast<double>(samples));
    scale(i) = rms > 1e-12 ? rms : 1.0;
  }
  if (structure.poly_degree > 0 || structure.activation == SsActivation::cubic) {
    // The polynomial's monomials (and cubic nodes) want states of size ≈ 1: x = S·x', S = diag(scale), so A' = S⁻¹·A·S,
    // B' = S⁻¹·B, C' = C·S (the same input-output map).
    const Eigen::VectorXd inverse = scale.cwiseInverse();
    ss.A = inverse.asDiagonal() * ss.A * scale.asDiagonal();
    ss.B = inverse.asDiagonal() * ss.B;
    ss.C = ss.C * scale.asDiagonal();
    states = inverse.asDiagonal() * states;
    scale.setOnes();
  }
  SsModel m = ss_model_from_linear(ss, structure, scale, linear.scaling, linear.fs, seed);
  ss_fit_encoder(m, us, ys, states);
  return m;
}

SsTraining train_ss(const SsModel& start, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                    const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, const SsTrainingOptions& options) {
  if (u.size() != y.size() || u_val.size() != y_val.size()) {
    throw std::invalid_argument("train_ss: input and output lengths differ");
  }
  const Eigen::Index L = start.structure.lags, T = options.window, samples = u.size();
  if (T < 1 || options.batch < 1) throw std::invalid_argument("train_ss: window and batch must be >= 1");
  if (samples < L + T) {
    throw std::invalid_argument("train_ss: " + std::to_string(samples) + " estimation samples, at least lags + window = " +
                                std::to_string(L + T) + " needed");
  }
  const bool has_val = u_val.size() != 0;
  const Eigen::VectorXd& us_sel = has_val ? u_val : u;
  const Eigen::VectorXd& ys_sel = has_val ? y_val : y;
  if (options.init >= us_sel.size()) throw std::invalid_argument("train_ss: init is not shorter than the selection data");
  const Eigen::VectorXd us = start.scaling.scale_u(u), ys = start.scaling.scale_y(y);

  const auto began = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count(); };
  SsTraining out;
  SsModel m = start;
  out.model = m;
  out.j_val_pct = ss_selection_j(m, us_sel, ys_sel, options.init);
  out.runaway = ss_free_run_runaway(m);
  out.history.push_back({0, ss_window_loss(m, us, ys, {std::vector<Eigen::Index>{L}, T}, nullptr), out.j_val_pct, seconds()});
  if (options.progress && !options.progress(out.history.back())) return out;

  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<Eigen::Index> draw(L, samples - T);
  const Eigen::Index per_epoch = std::max<Eigen::Index>(options.batch, samples / T);
  Adam adam(m.theta.size(), options.adam);
  std::vector<Eigen::Index> starts(static_cast<std::size_t>(options.batch));
  Eigen::VectorXd gradient;
  int since_best = 0;
  for (int epoch = 1; epoch <= options.max_epochs; ++epoch) {
    if (options.final_learning_rate > 0.0) {
      // α(epoch) = α₀·(α_final/α₀)^((epoch − 1)/max_epochs)
      const double progress = static_cast<double>(epoch - 1) / options.max_epochs;
      adam.options().learning_rate =
          options.adam.learning_rate * std::pow(options.final_learning_rate / options.adam.learning_rate, progress);
    }
    double loss_sum = 0.0;
    Eigen::Index steps = 0;
    for (Eigen::Index done = 0; done < per_epoch; done += options.batch) {
      for (Eigen::Index& k0 : starts) k0 = draw(rng);
      const double loss = ss_window_loss(m, us, ys, {starts, T}, &gradient);
      if (!std::isfinite(loss) || !gradient.allFinite()) continue;  // a diverging window: no step from it
      adam.step(m.theta, gradient);
      loss_sum += loss;
      ++steps;
    }
    const double j = ss_selection_j(m, us_sel, ys_sel, options.init);
    out.history.push_back({epoch, steps > 0 ? loss_sum / static_cast<double>(steps) : NAN, j, seconds()});
    if (ss_keep_if_better(m, j, epoch, out)) {
      since_best = 0;
    } else {
      ++since_best;
    }
    if (options.progress && !options.progress(out.history.back())) break;
    if (options.patience > 0 && since_best >= options.patience) break;
  }
  out.seconds = seconds();
  return out;
}

namespace {

// What liblbfgs's C callbacks reach through their `instance` pointer.
struct LbfgsRun {
  SsModel model;
  const SsStackedLoss* loss;
  const Eigen::VectorXd *u_sel, *y_sel;
  Eigen::Index init;
  const std::function<bool(const SsTrainingRecord&)>* progress;
  SsTraining* out;
  std::chrono::steady_clock::time_point began;
  Eigen::VectorXd gradient;
  double start_loss;
};

lbfgsfloatval_t lbfgs_evaluate(void* instance, const lbfgsfloatval_t* x, lbfgsfloatval_t* g, int n, lbfgsfloatval_t) {
  auto& run = *static_cast<LbfgsRun*>(instance);
  const double loss = (*run.loss)(Eigen::Map<const Eigen::VectorXd>(x, n), &run.gradient);
  if (!std::isfinite(loss) || !run.gradient.allFinite()) {
    // A trial step so long that a window's simulation ran away (a cubic state term grows fast): a finite
    // loss far above the start's, so that More–Thuente's interpolation stays finite and shortens the step.
    Eigen::Map<Eigen::VectorXd>(g, n).setZero();
    return 1e6 * (run.start_loss + 1.0);
  }
  Eigen::Map<Eigen::VectorXd>(g, n) = run.gradient;
  return loss;
}

int lbfgs_progress(void* instance, const lbfgsfloatval_t* x, const lbfgsfloatval_t*, lbfgsfloatval_t fx, lbfgsfloatval_t,
                   lbfgsfloatval_t, lbfgsfloatval_t, int, int k, int) {
  auto& run = *static_cast<LbfgsRun*>(instance);
  run.model.theta = Eigen::Map<const Eigen::VectorXd>(x, run.model.theta.size());
  const double j = ss_selection_j(run.model, *run.u_sel, *run.y_sel, run.init);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - run.began).count();
  run.out->history.push_back({k, fx, j, seconds});
  ss_keep_if_better(run.model, j, k, *run.out);
  return *run.progress && !(*run.progress)(run.out->history.back()) ? 1 : 0;
}

}  // namespace

SsTraining ss_lbfgs(const SsModel& start, const Eigen::VectorXd& z0, const SsStackedLoss& loss,
                    const Eigen::VectorXd& u_sel, const Eigen::VectorXd& y_sel, Eigen::Index init, int iterations,
                    const std::function<bool(const SsTrainingRecord&)>& progress) {
  SsTraining out;
  out.model = start;
  LbfgsRun run{start, &loss, &u_sel, &y_sel, init, &progress, &out, std::chrono::steady_clock::now(), {}, 0.0};
  out.j_val_pct = ss_selection_j(start, u_sel, y_sel, init);
  out.runaway = ss_free_run_runaway(start);
  run.start_loss = loss(z0, nullptr);
  out.history.push_back({0, run.start_loss, out.j_val_pct, 0.0});
  if (progress && !progress(out.history.back())) return out;

  const int n = static_cast<int>(z0.size());
  lbfgsfloatval_t* x = lbfgs_malloc(n);
  if (x == nullptr) throw std::bad_alloc();
  Eigen::Map<Eigen::VectorXd>(x, n) = z0;
  lbfgs_parameter_t param;
  lbfgs_parameter_init(&param);
  param.max_iterations = iterations;
  param.epsilon = 0.0;  // no gradient-norm stop: the iterations and the selection J decide
  param.delta = 0.0;
  // With the polynomial or cubic nodes, a long trial step runs a window's simulation away (the loss above):
  // halving the step until the loss falls (Armijo, then Wolfe's curvature condition) recovers where
  // More–Thuente's interpolation gives up.
  if (start.structure.poly_degree > 0 || start.structure.activation == SsActivation::cubic) {
    param.linesearch = LBFGS_LINESEARCH_BACKTRACKING_WOLFE;
  }
  lbfgsfloatval_t fx = 0.0;
  out.status = lbfgs(n, x, &fx, lbfgs_evaluate, lbfgs_progress, &run, &param);  // any iterate kept
  lbfgs_free(x);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - run.began).count();
  return out;
}

SsTraining polish_ss(const SsModel& start, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                     const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, const SsPolishOptions& options) {
  if (u.size() != y.size() || u_val.size() != y_val.size()) {
    throw std::invalid_argument("polish_ss: input and output lengths differ");
  }
  const Eigen::Index L = start.structure.lags, T = options.window;
  if (T < 1 || u.size() < L + T) {
    throw std::invalid_argument("polish_ss: " + std::to_string(u.size()) + " estimation samples, at least lags + window = " +
                                std::to_string(L + T) + " needed");
  }
  const bool has_val = u_val.size() != 0;
  if (options.init >= (has_val ? u_val : u).size()) throw std::invalid_argument("polish_ss: init is not shorter than the selection data");
  const Eigen::VectorXd us = start.scaling.scale_u(u), ys = start.scaling.scale_y(y);
  std::vector<Eigen::Index> starts;
  for (Eigen::Index k0 = L; k0 + T <= u.size(); k0 += T) starts.push_back(k0);
  SsModel model = start;
  const SsStackedLoss loss = [&](const Eigen::VectorXd& theta, Eigen::VectorXd* gradient) {
    model.theta = theta;
    return ss_window_loss(model, us, ys, {starts, T}, gradient);
  };
  return ss_lbfgs(start, start.theta, loss, has_val ? u_val : u, has_val ? y_val : y, options.init, options.iterations,
                  options.progress);
}

}  // namespace panelbass::models

// Structure selection for the NARX network. Choices beyond the header:
// - OBS uses the Gauss–Newton matrix H = 1/M·Σψψᵀ of V = 1/(2M)·Σe² as the Hessian (exact at a perfect
//   fit, and what LM uses), so a saliency is an increase of V. A net with redundant weights has a singular
//   H; it is damped by δ·mean(diag H)·I before inversion (Hassibi & Stork start H⁻¹ at α⁻¹·I likewise).
//   A dead node's weights then have saliency ≈ δ·θ²/2 and go first, as they should.
// - H⁻¹ is formed once per round for the free weights (a reduced LDLT solve) and downdated rank-one after
//   each removal in the round; the retraining after the round moves θ, so the next round forms it anew.
// - Retraining minimises the estimation loss (no early stopping); the validation J only accepts or
//   rejects a round, against the unpruned model's validation J.
// - Growth starts each larger net from the trained smaller one (new node: fresh [5F] input weights, zero
//   output weight), so the larger net starts at the smaller one's J and a trained improvement is due to
//   the node, not to a luckier initialisation; the untrained grown net is kept if training ends worse,
//   so J_est never rises with a node.
#include "models/narx/narx_structure.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "models/io/number_text.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

void require_sizes(const Eigen::MatrixXd& H_inv, const Eigen::VectorXd& theta, const char* where) {
  if (H_inv.rows() != theta.size() || H_inv.cols() != theta.size()) {
    throw std::invalid_argument(std::string(where) + ": H⁻¹ is " + std::to_string(H_inv.rows()) + "x" + std::to_string(H_inv.cols()) + " but θ has " + std::to_string(theta.size()) + " entries");
  }
}

/// [2A] simulation J in percent (scaled data): with init > 0 the first init measured outputs set the state
/// and J runs over k ≥ init (the J a trained model reports, TrainingOptions::init); else from rest over
/// k ≥ skip. +∞ for a non-finite simulation.
double j_sim(const NarxModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index skip,
             Eigen::Index init) {
  const Eigen::VectorXd yhat = m.simulate_scaled(u, y, init);
  if (!yhat.allFinite()) return std::numeric_limits<double>::infinity();
  return j_percent(yhat, y, init > 0 ? init : skip);
}

void require_data(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index skip, const char* where,
                  const char* which) {
  if (u.size() != y.size()) {
    throw std::invalid_argument(std::string(where) + ": " + which + " input has " + std::to_string(u.size()) + " samples, output " + std::to_string(y.size()));
  }
  if (u.size() <= skip) {
    throw std::invalid_argument(std::string(where) + ": " + which + " data has " + std::to_string(u.size()) + " samples, no more than the transient skip of " + std::to_string(skip));
  }
}

void require_pruning_options(const PruningOptions& o) {
  constexpr const char* where = "OBS pruning";
  if (!(o.relative_tolerance >= 0.0) || !std::isfinite(o.relative_tolerance)) {
    throw std::invalid_argument(std::string(where) + ": relative_tolerance must be a finite number ≥ 0, got " + number_text(o.relative_tolerance));
  }
  if (!(o.absolute_tolerance_pct >= 0.0) || !std::isfinite(o.absolute_tolerance_pct)) {
    throw std::invalid_argument(std::string(where) + ": absolute_tolerance_pct must be a finite number ≥ 0, got " + number_text(o.absolute_tolerance_pct));
  }
  if (o.batch < 1) throw std::invalid_argument(std::string(where) + ": batch must be ≥ 1, got " + std::to_string(o.batch));
  if (o.init < 0) throw std::invalid_argument(std::string(where) + ": init must be ≥ 0, got " + std::to_string(o.init));
  if (o.retrain_iterations < 0) {
    throw std::invalid_argument(std::string(where) + ": retrain_iterations must be ≥ 0, got " + std::to_string(o.retrain_iterations));
  }
  if (o.max_removed < -1) {
    throw std::invalid_argument(std::string(where) + ": max_removed must be ≥ 0 or −1 (no limit), got " + std::to_string(o.max_removed));
  }
  if (o.min_free < 1) throw std::invalid_argument(std::string(where) + ": min_free must be ≥ 1, got " + std::to_string(o.min_free));
  if (!(o.hessian_damping > 0.0) || !std::isfinite(o.hessian_damping)) {
    throw std::invalid_argument(std::string(where) + ": hessian_damping must be a finite number > 0, got " + number_text(o.hessian_damping));
  }
  if (o.mode == TrainingMode::oem_s) {
    throw std::invalid_argument(std::string(where) +
                                ": mode oem-s has no Hessian (its static sensitivities are not the gradient of "
                                "the simulation loss); use oem-d, oem-n or pem");
  }
  if (o.transient_skip < -1) {
    throw std::invalid_argument(std::string(where) + ": transient_skip must be ≥ 0 or −1 (= 2·(na + nb))");
  }
}

/// H⁻¹ over the free weights (mask 1) of H + δ·mean(diag H_free)·I, embedded in P×P with zero rows and
/// columns for the pruned weights.
Eigen::MatrixXd free_inverse(const Eigen::MatrixXd& H, const Eigen::VectorXd& mask, double damping) {
  const Eigen::Index P = H.rows();
  std::vector<Eigen::Index> free;
  for (Eigen::Index p = 0; p < P; ++p) {
    if (mask[p] != 0.0) free.push_back(p);
  }
  const auto F = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd Hf(F, F);
  for (Eigen::Index i = 0; i < F; ++i) {
    for (Eigen::Index j = 0; j < F; ++j) Hf(i, j) = H(free[i], free[j]);
  }
  const double level = std::max(Hf.diagonal().mean(), std::numeric_limits<double>::min());
  Hf.diagonal().array() += damping * level;
  const Eigen::MatrixXd Hf_inv = Hf.ldlt().solve(Eigen::MatrixXd::Identity(F, F));
  Eigen::MatrixXd H_inv = Eigen::MatrixXd::Zero(P, P);
  for (Eigen::Index i = 0; i < F; ++i) {
    for (Eigen::Index j = 0; j < F; ++j) H_inv(free[i], free[j]) = Hf_inv(i, j);
  }
  return H_inv;
}

/// The network of `model` (one hidden layer of h nodes) with node h + 1 added: input weights and bias of
/// a fresh [5F] initialisation (seed), output weight 0, so its output equals the original's.
NarxModel with_added_node(const NarxModel& model, std::uint64_t seed) {
  const int h = model.structure.hidden.front();
  const Eigen::Index n = model.net.inputs();
  NarxStructure s = model.structure;
  s.hidden = {h + 1};
  NarxModel grown = NarxModel::with_structure(s, model.scaling, model.fs);
  grown.meta = model.meta;
  Mlp fresh(static_cast<int>(n), {h + 1});
  fresh.initialize(1.0, seed);
  const Eigen::VectorXd& old_theta = model.net.parameters();
  const Eigen::VectorXd& new_node = fresh.parameters();
  Eigen::VectorXd& theta = grown.net.parameters();
  // θ layout (mlp.h): W (h×n, row by row), b (h), w_out (h), b_out.
  theta.head(h * n) = old_theta.head(h * n);
  theta.segment(h * n, n) = new_node.segment(h * n, n);
  const Eigen::Index b_old = h * n, b_new = (h + 1) * n;
  theta.segment(b_new, h) = old_theta.segment(b_old, h);
  theta[b_new + h] = new_node[b_new + h];
  const Eigen::Index out_old = b_old + h, out_new = b_new + h + 1;
  theta.segment(out_new, h) = old_theta.segment(out_old, h);
  theta[out_new + h] = 0.0;                   // the new node's output weight: the output is unchanged
  theta[out_new + h + 1] = old_theta[out_old + h];  // b_out
  return grown;
}

}  // namespace

ObsRemoval obs_removal(const Eigen::MatrixXd& H_inv, const Eigen::VectorXd& theta, Eigen::Index q) {
  require_sizes(H_inv, theta, "obs_removal");
  if (q < 0 || q >= theta.size()) {
    throw std::invalid_argument(std::string("obs_removal: weight ") + std::to_string(q) + " is out of range [0, " + std::to_string(theta.size()) + ")");
  }
  const double hqq = H_inv(q, q);
  if (!(hqq > 0.0) || !std::isfinite(hqq)) {
    throw std::invalid_argument(std::string("obs_removal: [H⁻¹]_qq of weight ") + std::to_string(q) + " is " + number_text(hqq) + ", not > 0");
  }
  ObsRemoval r;
  r.index = q;
  // OBS: L_q = θ_q² / (2 [H⁻¹]_qq),  δθ = −θ_q/[H⁻¹]_qq · H⁻¹ e_q
  r.saliency = theta[q] * theta[q] / (2.0 * hqq);
  r.delta = (-theta[q] / hqq) * H_inv.col(q);
  r.delta[q] = -theta[q];  // exactly: θ_q + δθ_q = 0
  return r;
}

ObsRemoval obs_best_removal(const Eigen::MatrixXd& H_inv, const Eigen::VectorXd& theta, const Eigen::VectorXd& mask) {
  require_sizes(H_inv, theta, "obs_best_removal");
  if (mask.size() != 0 && mask.size() != theta.size()) {
    throw std::invalid_argument(std::string("obs_best_removal: mask has ") + std::to_string(mask.size()) + " entries, θ " + std::to_string(theta.size()));
  }
  Eigen::Index best = -1;
  double best_saliency = std::numeric_limits<double>::infinity();
  // OBS: L_q = θ_q² / (2 [H⁻¹]_qq) for every free q; the least goes
  for (Eigen::Index q = 0; q < theta.size(); ++q) {
    if (mask.size() != 0 && mask[q] == 0.0) continue;
    const double hqq = H_inv(q, q);
    if (!(hqq > 0.0) || !std::isfinite(hqq)) continue;
    const double L = theta[q] * theta[q] / (2.0 * hqq);
    if (best < 0 || L < best_saliency) {
      best = q;
      best_saliency = L;
    }
  }
  if (best < 0) throw std::invalid_argument("obs_best_removal: no free weight with [H⁻¹]_qq > 0 is left");
  return obs_removal(H_inv, theta, best);
}

void obs_downdate_inverse(Eigen::MatrixXd& H_inv, Eigen::Index q) {
  if (H_inv.rows() != H_inv.cols() || q < 0 || q >= H_inv.rows()) {
    throw std::invalid_argument(std::string("obs_downdate_inverse: weight ") + std::to_string(q) + " is out of range for a " + std::to_string(H_inv.rows()) + "x" + std::to_string(H_inv.cols()) + " H⁻¹");
  }
  const double hqq = H_inv(q, q);
  if (!(hqq > 0.0) || !std::isfinite(hqq)) {
    throw std::invalid_argument(std::string("obs_downdate_inverse: [H⁻¹]_qq of weight ") + std::to_string(q) + " is " + number_text(hqq) + ", not > 0");
  }
  // (H with row/column q removed)⁻¹ = H⁻¹ − H⁻¹e_q e_qᵀH⁻¹ / [H⁻¹]_qq  (Schur complement)
  const Eigen::VectorXd column = H_inv.col(q);
  H_inv.noalias() -= (column / hqq) * column.transpose();
  H_inv.row(q).setZero();
  H_inv.col(q).setZero();
}

PruningResult prune_obs(const NarxModel& trained, const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est,
                        const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, const PruningOptions& options) {
  constexpr const char* where = "OBS pruning";
  require_pruning_options(options);
  const NarxStructure& s = trained.structure;
  const Eigen::Index init = options.init;
  const Eigen::Index skip =
      std::max(options.transient_skip >= 0 ? options.transient_skip : 2 * (s.na + s.nb), init);
  if (u_val.size() == 0 && y_val.size() == 0) {
    throw std::invalid_argument(std::string(where) + ": validation data is needed (it decides when to stop)");
  }
  require_data(u_est, y_est, skip, where, "estimation");
  require_data(u_val, y_val, skip, where, "validation");
  const Eigen::Index P = trained.net.parameter_count();

  TrainingOptions retrain;
  retrain.modes = {options.mode};
  retrain.optimizer = Optimizer::lm;
  retrain.max_iterations = options.retrain_iterations;
  retrain.transient_skip = skip;
  retrain.init = init;
  retrain.early_stopping = false;
  retrain.weights = options.weights;

  PruningResult result;
  result.model = trained;
  result.mask = Eigen::VectorXd::Ones(P);
  result.j_est_before_pct = result.j_est_after_pct = j_sim(trained, u_est, y_est, skip, init);
  result.j_val_before_pct = result.j_val_after_pct = j_sim(trained, u_val, y_val, skip, init);
  if (!std::isfinite(result.j_val_before_pct) || !std::isfinite(result.j_est_before_pct)) {
    throw std::invalid_argument(std::string(where) + ": the trained model's simulation is not finite");
  }
  result.j_val_limit_pct =
      result.j_val_before_pct * (1.0 + options.relative_tolerance) + options.absolute_tolerance_pct;
  const Eigen::Index max_removed = options.max_removed < 0 ? P : options.max_removed;

  int batch = options.batch;
  Eigen::MatrixXd H_inv;  // of the current model over its free weights; empty = to be formed
  while (true) {
    const auto free = static_cast<Eigen::Index>(result.mask.sum());
    if (result.removed >= max_removed) {
      result.stop_reason = std::string("max_removed = ") + std::to_string(max_removed) + " weights removed";
      break;
    }
    if (free <= options.min_free) {
      result.stop_reason = std::string("min_free = ") + std::to_string(options.min_free) + " free weights left";
      break;
    }
    const Eigen::Index count =
        std::min<Eigen::Index>({batch, max_removed - result.removed, free - options.min_free});
    if (H_inv.size() == 0) {
      const Eigen::MatrixXd H = gauss_newton_hessian(result.model, u_est, y_est, options.mode, skip, options.weights, init);
      H_inv = free_inverse(H, result.mask, options.hessian_damping);
    }

    NarxModel candidate = result.model;
    Eigen::VectorXd mask = result.mask;
    Eigen::MatrixXd H_inv_round = H_inv;
    Eigen::VectorXd& theta = candidate.net.parameters();
    PruningStep step;
    // OBS: L_q = θ_q² / (2 [H⁻¹]_qq),  δθ = −θ_q/[H⁻¹]_qq · H⁻¹ e_q; then H⁻¹ without q (rank-one)
    for (Eigen::Index i = 0; i < count; ++i) {
      const ObsRemoval r = obs_best_removal(H_inv_round, theta, mask);
      theta += r.delta;
      theta[r.index] = 0.0;
      mask[r.index] = 0.0;
      obs_downdate_inverse(H_inv_round, r.index);
      step.removed.push_back(r.index);
      step.saliency.push_back(r.saliency);
    }
    theta.array() *= mask.array();  // pruned weights exactly 0
    if (options.retrain_iterations > 0) {
      retrain.mask = mask;
      candidate = train_narx(candidate, u_est, y_est, Eigen::VectorXd(), Eigen::VectorXd(), retrain).model;
    }
    step.free = free - count;
    step.j_est_pct = j_sim(candidate, u_est, y_est, skip, init);
    step.j_val_pct = j_sim(candidate, u_val, y_val, skip, init);
    step.accepted = step.j_val_pct <= result.j_val_limit_pct;
    result.steps.push_back(step);

    if (step.accepted) {
      result.model = std::move(candidate);
      result.mask = mask;
      result.removed += static_cast<int>(count);
      result.j_est_after_pct = step.j_est_pct;
      result.j_val_after_pct = step.j_val_pct;
      H_inv.resize(0, 0);  // θ moved: form H⁻¹ anew
    } else if (count > 1) {
      batch = static_cast<int>(count / 2);  // undo the round, retry with fewer removals
    } else {
      result.stop_reason =
          std::string("removing weight ") + std::to_string(step.removed.front()) + " raised the validation J to " + number_text(step.j_val_pct, 4) + " %, above the limit " + number_text(result.j_val_limit_pct, 4) + " % (" + number_text(result.j_val_before_pct, 4) + " % unpruned, relative tolerance " + number_text(options.relative_tolerance) + ", absolute " + number_text(options.absolute_tolerance_pct) + ")";
      break;
    }
  }
  result.model.meta["pruning"] = {{"method", "obs"},
                                  {"removed", result.removed},
                                  {"j_val_before_pct", result.j_val_before_pct},
                                  {"j_val_after_pct", result.j_val_after_pct}};
  return result;
}

GrowthResult grow_hidden_nodes(const NarxStructure& base, const Scaling& scaling, double fs, const Eigen::VectorXd& u_est,
                               const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val,
                               const TrainingOptions& options, int max_hidden, std::uint64_t seed,
                               const GrowthOptions& growth) {
  constexpr const char* where = "hidden-node growth";
  if (max_hidden < 1) throw std::invalid_argument(std::string(where) + ": max_hidden must be ≥ 1, got " + std::to_string(max_hidden));
  if (!(growth.threshold_factor > 0.0) || !std::isfinite(growth.threshold_factor)) {
    throw std::invalid_argument(std::string(where) + ": threshold_factor must be a finite number > 0, got " + number_text(growth.threshold_factor));
  }
  if (growth.restarts < 0) {
    throw std::invalid_argument(std::string(where) + ": restarts must be ≥ 0, got " + std::to_string(growth.restarts));
  }
  if (options.mask.size() != 0) {
    throw std::invalid_argument(std::string(where) + ": a training mask cannot be used (P changes with every node)");
  }
  if (options.transient_skip < -1) {
    throw std::invalid_argument(std::string(where) + ": transient_skip must be ≥ 0 or −1 (= 2·(na + nb))");
  }
  NarxStructure s = base;
  s.hidden = {1};
  const Eigen::Index init = options.init;
  const Eigen::Index skip =
      std::max(options.transient_skip >= 0 ? options.transient_skip : 2 * (s.na + s.nb), init);
  require_data(u_est, y_est, skip, where, "estimation");
  const bool has_validation = u_val.size() > 0 || y_val.size() > 0;
  if (has_validation) require_data(u_val, y_val, skip, where, "validation");
  const auto N = static_cast<double>(u_est.size() - skip);
  const int dX = s.inputs() + 2;  // the new node's input weights, its bias and its output weight
  const double threshold = growth.threshold_factor * dX / N;
  const std::string threshold_text =
      growth.threshold_factor == 1.0 ? std::string("dX/N = ") + std::to_string(dX) + "/" + std::to_string(std::llround(N))
                                     : number_text(growth.threshold_factor) + "·dX/N = " + number_text(growth.threshold_factor) + "·" + std::to_string(dX) + "/" + std::to_string(std::llround(N));

  // The trained net of `hidden` nodes with the least estimation J among the warm start (if given) and
  // the fresh random starts; seeds differ per size and start.
  auto train_size = [&](int hidden, const NarxModel* warm) {
    NarxModel best;
    double best_j = std::numeric_limits<double>::infinity();
    auto consider = [&](const NarxModel& start) {
      NarxModel trained = train_narx(start, u_est, y_est, u_val, y_val, options).model;
      const double j = j_sim(trained, u_est, y_est, skip, init);
      if (j < best_j || !std::isfinite(best_j)) {
        best_j = j;
        best = std::move(trained);
      }
    };
    if (warm != nullptr) {
      // The grown net untrained is a candidate too: its J is the smaller net's, so that a training run that
      // ends worse (PEM first can leave a basin of the simulation loss) cannot make a node look harmful.
      const NarxModel grown = with_added_node(*warm, seed + 1000 * static_cast<std::uint64_t>(hidden));
      best_j = j_sim(grown, u_est, y_est, skip, init);
      best = grown;
      consider(grown);
    }
    const int fresh = growth.restarts + (warm == nullptr ? 1 : 0);
    for (int r = 0; r < fresh; ++r) {
      NarxStructure sized = s;
      sized.hidden = {hidden};
      NarxModel start = NarxModel::with_structure(sized, scaling, fs);
      start.net.initialize(1.0, seed + 1000 * static_cast<std::uint64_t>(hidden) + 1 + static_cast<std::uint64_t>(r));
      consider(start);
    }
    return best;
  };

  auto evaluate = [&](const NarxModel& m, int hidden) {
    GrowthStep step;
    step.hidden = hidden;
    step.params = m.net.parameter_count();
    step.j_est_pct = j_sim(m, u_est, y_est, skip, init);
    step.j_val_pct = has_validation ? j_sim(m, u_val, y_val, skip, init) : std::numeric_limits<double>::quiet_NaN();
    return step;
  };

  GrowthResult result;
  result.model = train_size(1, nullptr);
  result.steps.push_back(evaluate(result.model, 1));
  result.chosen_hidden = 1;
  for (int h = 2; h <= max_hidden; ++h) {
    const double j_before = result.steps.back().j_est_pct;
    if (!(j_before > 0.0)) {
      result.rule = std::to_string(h - 1) + " hidden nodes fit the estimation data exactly (J_est = 0); no node is added";
      break;
    }
    NarxModel trained = train_size(h, &result.model);
    GrowthStep step = evaluate(trained, h);
    // ch. 6: keep the node if (J(h−1) − J(h)) / J(h−1) > dX/N
    step.improvement = (j_before - step.j_est_pct) / j_before;
    step.threshold = threshold;
    result.steps.push_back(step);
    if (!(step.improvement > threshold)) {
      result.rule = std::to_string(h - 1) + " hidden nodes: adding node " + std::to_string(h) + " improved J_est by " + number_text(100.0 * step.improvement, 4) + " % (relative, " + number_text(j_before, 4) + " % -> " + number_text(step.j_est_pct, 4) + " %), not more than " + threshold_text.c_str() + " = " + number_text(100.0 * threshold, 4) + " %";
      break;
    }
    result.model = std::move(trained);
    result.chosen_hidden = h;
  }
  if (result.rule.empty()) {
    result.rule = std::to_string(result.chosen_hidden) + " hidden nodes: max_hidden reached, every node added improved J_est by more than " + threshold_text.c_str() + " = " + number_text(100.0 * threshold, 4) + " %";
  }
  result.model.meta["growth"] = {{"rule", "dX/N"},
                                 {"threshold_factor", growth.threshold_factor},
                                 {"chosen_hidden", result.chosen_hidden},
                                 {"dX", dX}};
  return result;
}

}  // namespace panelbass::models

// NARX training: the driver (checks, the optimisers' passes, early stopping) over the sweeps of
// narx_gradients. Choices beyond the header:
// - An iteration is one pass over the data. LM and the line search stop a mode when no step lowers the
//   mode's loss; sd stops a mode if θ turns non-finite (keeping the parameters before that pass).
// - oem_n: sd takes one full-batch step per pass (a numerical gradient per batch would cost 2P
//   simulations each); lm forms the numerical Jacobian column by column (2P simulations, stored
//   (N−skip)×P), which suits small nets only.
// - With early stopping and validation data, each mode after the first starts from the kept parameters.
// - A mask (options.mask) holds pruned parameters at 0: they are zeroed at the start, and every step is
//   multiplied by the mask after its gradient and (LM) Gauss–Newton matrix have their pruned entries,
//   rows and columns zeroed, which makes the LM system block-diagonal: the reduced system for the free
//   parameters, and δ = 0 exactly for the pruned ones.
#include "models/narx/narx_training.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "models/narx/narx_gradients.h"
#include "models/optimization/evidence_decay.h"
#include "models/optimization/levenberg_marquardt.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

using narx::Buffers;
using narx::Feedback;
using narx::feedback_of;
using narx::gradient_sweep;
using narx::kFiniteDifferenceStep;
using narx::mode_gradient;
using narx::numerical_gradient;
using narx::numerical_normal_equations;
using narx::output_loss;

// ----- validation --------------------------------------------------------------------------------

void require_finite(const Eigen::VectorXd& v, const std::string& what) {
  for (Eigen::Index k = 0; k < v.size(); ++k) {
    if (!std::isfinite(v[k])) {
      throw std::invalid_argument("NARX training: " + what + " is not finite at sample " + std::to_string(k));
    }
  }
}

void require_model(const NarxModel& model) {
  const NarxStructure& s = model.structure;
  if (s.na < 0 || s.nb < 0 || s.nk < 0) {
    throw std::invalid_argument("NARX training: na, nb and nk must be ≥ 0 (na=" + std::to_string(s.na) +
                                ", nb=" + std::to_string(s.nb) + ", nk=" + std::to_string(s.nk) + ")");
  }
  if (model.net.inputs() != s.inputs()) {
    throw std::invalid_argument("NARX training: the network has " + std::to_string(model.net.inputs()) +
                                " inputs but the structure needs na + nb + 1 = " + std::to_string(s.inputs()));
  }
  if (model.net.parameters().size() != model.net.parameter_count()) {
    throw std::invalid_argument("NARX training: θ has " + std::to_string(model.net.parameters().size()) +
                                " entries, the network " + std::to_string(model.net.parameter_count()));
  }
  require_finite(model.net.parameters(), "the initial parameter vector θ");
}

void require_data(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index skip, const std::string& which) {
  if (u.size() != y.size()) {
    throw std::invalid_argument("NARX training: " + which + " input has " + std::to_string(u.size()) +
                                " samples, output " + std::to_string(y.size()));
  }
  if (skip < 0) throw std::invalid_argument("NARX training: transient skip must be ≥ 0, got " + std::to_string(skip));
  if (u.size() <= skip) {
    throw std::invalid_argument("NARX training: " + which + " data has " + std::to_string(u.size()) +
                                " samples; the loss needs more than the transient skip of " + std::to_string(skip));
  }
  require_finite(u, which + " input");
  require_finite(y, which + " output");
}

/// init measured outputs, 0 ≤ init ≤ skip (the loss starts no earlier than the free run).
void require_init(Eigen::Index init, Eigen::Index skip) {
  if (init < 0 || init > skip) {
    throw std::invalid_argument("NARX training: init = " + std::to_string(init) + " must be within [0, skip = " +
                                std::to_string(skip) + "]");
  }
}

/// Weights are empty, or one finite w(k) ≥ 0 per sample with a positive total over k ≥ skip.
void require_weights(const Eigen::VectorXd& w, Eigen::Index samples, Eigen::Index skip, const std::string& which) {
  if (w.size() == 0) return;
  if (w.size() != samples) {
    throw std::invalid_argument("NARX training: " + which + " weights have " + std::to_string(w.size()) +
                                " entries, the data " + std::to_string(samples) + " samples");
  }
  for (Eigen::Index k = 0; k < w.size(); ++k) {
    if (!std::isfinite(w[k]) || w[k] < 0.0) {
      throw std::invalid_argument("NARX training: " + which + " weight at sample " + std::to_string(k) + " is " +
                                  std::to_string(w[k]) + " (expected a finite number ≥ 0)");
    }
  }
  if (!(w.tail(samples - skip).sum() > 0.0)) {
    throw std::invalid_argument("NARX training: " + which + " weights are all 0 after the transient skip");
  }
}

/// A Buffers for `u` with `weights` set (checked).
Buffers weighted_buffers(const NarxModel& model, const Eigen::VectorXd& u, Eigen::Index skip,
                         const Eigen::VectorXd& weights, const std::string& which) {
  require_weights(weights, u.size(), skip, which);
  Buffers b(model, u.size());
  b.set_weights(weights, u.size(), skip);
  return b;
}

// ----- training ----------------------------------------------------------------------------------

/// Levenberg–Marquardt here: λ from 1e-3 (per mode) within [1e-12, 1e12], ÷10 on success, ×10 on failure,
/// 12 retries, the damping λ·(diag H + 1e-9·mean diag H) + 1e-12·(1 + max diag H).
constexpr LmSettings kLmSettings{.damping = LmDamping::relative_to_mean_with_ridge,
                                 .initial_lambda = 1e-3,
                                 .min_lambda = 1e-12,
                                 .max_lambda = 1e12,
                                 .retries = 12};

/// Zeroes the pruned (mask 0) entries of g and, if given, rows and columns of H; no-op for an empty mask.
void apply_mask(const Eigen::VectorXd& mask, Eigen::VectorXd& g, Eigen::MatrixXd* H) {
  if (mask.size() == 0) return;
  g.array() *= mask.array();
  if (H != nullptr) {
    H->array().colwise() *= mask.array();
    H->array().rowwise() *= mask.transpose().array();
  }
}

/// The data and the scratch space of one train_narx call.
struct Trainer {
  const Eigen::VectorXd& u_est;
  const Eigen::VectorXd& y_est;
  const Eigen::VectorXd& u_val;
  const Eigen::VectorXd& y_val;
  Eigen::Index skip;
  Eigen::Index j_start;  ///< where the J figures start: init when given, else the transient skip
  bool has_validation;
  const TrainingOptions& options;
  Buffers est;
  Buffers val;
  NarxModel trial;          ///< a copy whose θ is overwritten by candidate steps
  Eigen::VectorXd g;
  Eigen::MatrixXd H;
  LevenbergMarquardt lm;    ///< its λ is reset per mode
  double decay;             ///< the weight decay D now: options.weight_decay, re-estimated with evidence_decay
  // oem_ms: the windows and histories, LM over the stack z = [θ; h_0; …], its gradient, matrix and mask
  std::optional<MultipleShooting> shooting;
  std::optional<LevenbergMarquardt> shooting_lm;
  Eigen::VectorXd z, gz, shooting_mask;
  Eigen::MatrixXd Hz;

  Trainer(const NarxModel& model, const Eigen::VectorXd& ue, const Eigen::VectorXd& ye, const Eigen::VectorXd& uv,
          const Eigen::VectorXd& yv, Eigen::Index skip_, const TrainingOptions& opt)
      : u_est(ue), y_est(ye), u_val(uv), y_val(yv), skip(skip_), j_start(opt.init > 0 ? opt.init : skip_),
        has_validation(uv.size() > 0), options(opt),
        est(weighted_buffers(model, ue, skip_, opt.weights, "estimation")),
        val(weighted_buffers(model, uv, has_validation ? skip_ : 0, has_validation ? opt.validation_weights : Eigen::VectorXd(),
                             "validation")),
        trial(model),
        lm(kLmSettings, opt.optimizer == Optimizer::lm ? model.net.parameter_count() : 0),
        decay(opt.weight_decay) {
    const Eigen::Index P = model.net.parameter_count();
    g.resize(P);
    if (opt.optimizer == Optimizer::lm) H.resize(P, P);
    est.init = opt.init;
    val.init = opt.init;
  }

  /// oem_ms from `m`: fresh windows, histories at the measured outputs, the penalty at its start, λ at its start.
  void start_shooting(const NarxModel& m) {
    shooting.emplace(m, u_est, y_est, skip, options.multiple_shooting, options.weights);
    const Eigen::Index P = m.net.parameter_count(), n = P + shooting->histories().size();
    shooting_lm.emplace(kLmSettings, n);
    z.resize(n);
    if (options.mask.size() != 0) {  // pruned weights stay held; every history is free
      shooting_mask = Eigen::VectorXd::Ones(n);
      shooting_mask.head(P) = options.mask;
    }
  }

  /// One Levenberg–Marquardt step of θ and the histories together on the multiple-shooting loss (plus the
  /// weight decay on θ); the penalty tightens after an accepted step. False when no step lowers the loss.
  bool shooting_step(NarxModel& m) {
    const Eigen::Index P = m.net.parameter_count();
    double V = shooting->gradient(m, shooting->histories(), gz, &Hz);
    if (decay != 0.0) {
      const double c = decay / est.weight_total;
      V += 0.5 * c * m.net.parameters().squaredNorm();
      gz.head(P).noalias() += c * m.net.parameters();
      Hz.diagonal().head(P).array() += c;
    }
    apply_mask(shooting_mask, gz, &Hz);
    z << m.net.parameters(), shooting->histories();
    const bool accepted = shooting_lm->step(Hz, gz, V, z, [&](const Eigen::VectorXd& candidate) {
                               trial.net.parameters() = candidate.head(P);
                               return shooting->loss(trial, candidate.tail(candidate.size() - P)) +
                                      decay_term(trial.net.parameters());
                             }, shooting_mask).accepted;
    if (!accepted) return false;
    m.net.parameters() = z.head(P);
    shooting->histories() = z.tail(z.size() - P);
    shooting->tighten();
    return true;
  }

  /// The criterion minimised: the mode's loss V plus the weight decay D/(2·Σw)·‖θ‖².
  double loss(const NarxModel& m, TrainingMode mode) {
    return output_loss(m, u_est, y_est, feedback_of(mode), skip, est) + decay_term(m.net.parameters());
  }

  /// D/(2·Σw)·‖θ‖² (NNSYSID's regularisation with D = weight_decay·I).
  double decay_term(const Eigen::VectorXd& theta) const {
    return decay == 0.0 ? 0.0 : 0.5 * decay / est.weight_total * theta.squaredNorm();
  }

  /// Adds the weight decay's share to V, g = dW/dθ (+ D/Σw·θ) and, if given, H (+ D/Σw·I).
  void add_decay(const Eigen::VectorXd& theta, double& V, Eigen::VectorXd& grad, Eigen::MatrixXd* hessian) const {
    if (decay == 0.0) return;
    const double c = decay / est.weight_total;
    V += 0.5 * c * theta.squaredNorm();
    grad.noalias() += c * theta;
    if (hessian != nullptr) hessian->diagonal().array() += c;
  }

  /// [2A] simulation J in percent over k ≥ j_start (the state from init measured outputs); +∞ for a
  /// non-finite simulation. With `weighted` and weights in b: Σ w·e² / Σ w·y² over k ≥ skip instead (the
  /// figure the weighted loss minimises).
  double j_sim(const NarxModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Buffers& b,
               bool weighted = false) {
    const double V = output_loss(m, u, y, Feedback::simulated, skip, b);
    if (!b.yhat.allFinite()) return std::numeric_limits<double>::infinity();
    if (!weighted || b.weight.size() == 0) return j_percent(b.yhat, y, j_start);
    const Eigen::Index M = y.size() - skip;
    return j_ratio_percent(2.0 * V * b.weight_total, b.weight.tail(M).dot(y.tail(M).cwiseAbs2()), "the weighted output");
  }

  TrainingRecord record(const NarxModel& m, int iteration, TrainingMode mode) {
    TrainingRecord r;
    r.iteration = iteration;
    r.mode = mode;
    r.j_est_pct = j_sim(m, u_est, y_est, est);
    r.j_val_pct = has_validation ? j_sim(m, u_val, y_val, val) : std::numeric_limits<double>::quiet_NaN();
    r.j_val_weighted_pct = val.weight.size() == 0 ? r.j_val_pct : j_sim(m, u_val, y_val, val, true);
    r.weight_decay = decay;
    return r;
  }

  /// One Levenberg–Marquardt step on this mode's Gauss–Newton matrix and gradient, the system reduced to
  /// the free parameters; false when no step within the retries lowers the mode's loss.
  bool lm_step(NarxModel& m, TrainingMode mode) {
    if (mode == TrainingMode::oem_ms) return shooting_step(m);
    double V;
    if (mode == TrainingMode::oem_n) {
      V = numerical_normal_equations(m, u_est, y_est, skip, kFiniteDifferenceStep, est, g, H);
    } else {
      // oem_s: the static Jacobian ∂F/∂θ with the simulation loss (the approximation of table 5.1)
      V = gradient_sweep(m, u_est, y_est, mode, skip, est, g, &H);
    }
    const double squared_error = 2.0 * V * est.weight_total;  // Σw·e² (w = 1: Σe²)
    add_decay(m.net.parameters(), V, g, &H);
    apply_mask(options.mask, g, &H);  // the reduced system over the free parameters
    const Eigen::VectorXd theta = m.net.parameters();  // H, g and V are of this θ
    const bool accepted = lm.step(H, g, V, m.net.parameters(), [&](const Eigen::VectorXd& candidate) {
                            trial.net.parameters() = candidate;
                            return loss(trial, mode);
                          }, options.mask).accepted;
    const EvidenceDecay rule = options.evidence_decay;
    if (rule == EvidenceDecay::all_modes || (rule == EvidenceDecay::output_error && mode != TrainingMode::pem)) {
      // the next iteration's criterion; JᵀJ + D·I = Σw·H
      decay = evidence_weight_decay(est.weight_total * H, squared_error, est.weight_total, decay, theta, options.mask);
    }
    return accepted;
  }

  /// Steepest descent along −dV/dθ with backtracking until Armijo's condition V(θ − t·g) ≤ V − c·t·‖g‖² holds.
  bool linesearch_step(NarxModel& m, TrainingMode mode, double& t) {
    double V = mode_gradient(m, u_est, y_est, mode, skip, kFiniteDifferenceStep, est, g);
    add_decay(m.net.parameters(), V, g, nullptr);
    apply_mask(options.mask, g, nullptr);
    const double slope = g.squaredNorm();
    if (!std::isfinite(V) || !std::isfinite(slope) || slope == 0.0) return false;
    constexpr double kArmijo = 1e-4;
    constexpr int kHalvings = 40;
    t *= 2.0;
    // [5E] θ ← θ − t·dV/dθ with t halved until Armijo's condition holds
    for (int attempt = 0; attempt < kHalvings; ++attempt, t *= 0.5) {
      trial.net.parameters() = m.net.parameters() - t * g;
      const double V_new = loss(trial, mode);
      if (std::isfinite(V_new) && V_new <= V - kArmijo * t * slope) {
        m.net.parameters() = trial.net.parameters();
        return true;
      }
    }
    return false;
  }

  /// [5C] one pass of steepest descent θ ← θ − α·dV/dθ, updated every L samples (L = batch, 0 = all).
  /// Within the pass the OEM simulation and the [5L] recursion run on across updates (the thesis's remark
  /// that with α small the effect of not recomputing the past is negligible). oem_n: one full-batch step.
  bool sd_pass(NarxModel& m, TrainingMode mode) {
    Eigen::VectorXd& theta = m.net.parameters();
    const double alpha = options.step;
    if (mode == TrainingMode::oem_n) {
      numerical_gradient(m, u_est, y_est, skip, kFiniteDifferenceStep, est, g);
      apply_mask(options.mask, g, nullptr);
      theta.noalias() -= alpha * g;  // [5E]
      return theta.allFinite();
    }
    const Eigen::Index L = options.batch == 0 ? u_est.size() - skip : options.batch;
    Buffers& b = est;
    b.grad.setZero();
    Eigen::Index in_batch = 0;
    double batch_weight = 0.0;
    const auto at_sample = [&](Eigen::Index k, double yk, const Eigen::VectorXd& psi) {
      // [5M] dV/dθ = Σ_{batch} w(k)·e(k)·dŷ(k)/dθ, averaged over the batch's weight
      b.grad.noalias() += (b.w(k) * (yk - y_est[k])) * psi;
      batch_weight += b.w(k);
      if (++in_batch == L) {
        apply_mask(options.mask, b.grad, nullptr);
        if (batch_weight > 0.0) theta.noalias() -= (alpha / batch_weight) * b.grad;  // [5C]
        b.grad.setZero();
        in_batch = 0;
        batch_weight = 0.0;
      }
    };
    narx::sweep_sensitivities(m, u_est, y_est, mode, skip, b, at_sample);
    apply_mask(options.mask, b.grad, nullptr);
    if (in_batch > 0 && batch_weight > 0.0) theta.noalias() -= (alpha / batch_weight) * b.grad;
    return theta.allFinite();
  }
};

/// oem_ms's loss has the histories besides θ: the functions of θ alone refuse it.
void require_single_record(TrainingMode mode) {
  if (mode == TrainingMode::oem_ms) {
    throw std::invalid_argument("NARX training: oem-ms has no loss of θ alone (its windows' histories are "
                                "parameters too); MultipleShooting computes it, train_narx trains with it");
  }
}

void require_options(const TrainingOptions& o) {
  if (o.modes.empty()) throw std::invalid_argument("NARX training: no training mode given");
  if (o.pem_max_iterations < -1) {
    throw std::invalid_argument("NARX training: pem_max_iterations must be ≥ 0 (or −1: max_iterations), got " +
                                std::to_string(o.pem_max_iterations));
  }
  if (!(o.pem_min_progress >= 0.0 && o.pem_min_progress < 1.0)) {
    throw std::invalid_argument("NARX training: pem_min_progress must be within [0, 1) (0: off), got " +
                                std::to_string(o.pem_min_progress));
  }
  if (o.max_iterations < 0) {
    throw std::invalid_argument("NARX training: max_iterations must be ≥ 0, got " + std::to_string(o.max_iterations));
  }
  if (o.optimizer == Optimizer::sd || o.optimizer == Optimizer::linesearch) {
    if (!(o.step > 0.0) || !std::isfinite(o.step)) {
      throw std::invalid_argument("NARX training: step α must be a finite number > 0, got " + std::to_string(o.step));
    }
  }
  if (o.batch < 0) throw std::invalid_argument("NARX training: batch must be ≥ 0 (0 = all samples)");
  if (!(o.weight_decay >= 0.0) || !std::isfinite(o.weight_decay)) {
    throw std::invalid_argument("NARX training: weight_decay must be a finite number ≥ 0, got " +
                                std::to_string(o.weight_decay));
  }
  if ((o.weight_decay > 0.0 || o.evidence_decay != EvidenceDecay::off) && o.optimizer == Optimizer::sd) {
    throw std::invalid_argument("NARX training: weight_decay needs --optimizer lm or linesearch (sd has none)");
  }
  if (o.transient_skip < -1) {
    throw std::invalid_argument("NARX training: transient_skip must be ≥ 0 or −1 (= 2·(na + nb))");
  }
  if (o.init < 0) throw std::invalid_argument("NARX training: init must be ≥ 0, got " + std::to_string(o.init));
  if (std::find(o.modes.begin(), o.modes.end(), TrainingMode::oem_ms) != o.modes.end() &&
      o.optimizer != Optimizer::lm) {
    throw std::invalid_argument("NARX training: oem-ms (multiple shooting) needs --optimizer lm, got " +
                                to_string(o.optimizer));
  }
  if (o.early_stopping && o.patience < 1) {
    throw std::invalid_argument("NARX training: patience must be ≥ 1, got " + std::to_string(o.patience));
  }
}

}  // namespace

TrainingMode parse_training_mode(const std::string& name) {
  if (name == "pem") return TrainingMode::pem;
  if (name == "oem-s") return TrainingMode::oem_s;
  if (name == "oem-d") return TrainingMode::oem_d;
  if (name == "oem-n") return TrainingMode::oem_n;
  if (name == "oem-ms") return TrainingMode::oem_ms;
  throw std::invalid_argument("unknown training mode \"" + name + "\" (expected pem, oem-s, oem-d, oem-n or oem-ms)");
}

std::string to_string(TrainingMode mode) {
  switch (mode) {
    case TrainingMode::pem: return "pem";
    case TrainingMode::oem_s: return "oem-s";
    case TrainingMode::oem_d: return "oem-d";
    case TrainingMode::oem_n: return "oem-n";
    case TrainingMode::oem_ms: return "oem-ms";
  }
  return "?";
}

EvidenceDecay parse_evidence_decay(const std::string& name) {
  if (name == "off") return EvidenceDecay::off;
  if (name == "all") return EvidenceDecay::all_modes;
  if (name == "oem") return EvidenceDecay::output_error;
  throw std::invalid_argument("unknown evidence decay \"" + name + "\" (expected off, all or oem)");
}

Optimizer parse_optimizer(const std::string& name) {
  if (name == "sd") return Optimizer::sd;
  if (name == "linesearch") return Optimizer::linesearch;
  if (name == "lm") return Optimizer::lm;
  throw std::invalid_argument("unknown optimizer \"" + name + "\" (expected sd, linesearch or lm)");
}

std::string to_string(Optimizer optimizer) {
  switch (optimizer) {
    case Optimizer::sd: return "sd";
    case Optimizer::linesearch: return "linesearch";
    case Optimizer::lm: return "lm";
  }
  return "?";
}

double training_loss(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y, TrainingMode mode,
                     Eigen::Index skip, const Eigen::VectorXd& weights, Eigen::Index init) {
  require_model(model);
  require_data(u, y, skip, "estimation");
  require_init(init, skip);
  require_single_record(mode);
  Buffers b = weighted_buffers(model, u, skip, weights, "estimation");
  b.init = init;
  return output_loss(model, u, y, feedback_of(mode), skip, b);
}

Eigen::VectorXd loss_gradient(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                              TrainingMode mode, Eigen::Index skip, double h, const Eigen::VectorXd& weights,
                              Eigen::Index init) {
  require_model(model);
  require_data(u, y, skip, "estimation");
  require_init(init, skip);
  require_single_record(mode);
  if (mode == TrainingMode::oem_n && !(h > 0.0 && std::isfinite(h))) {
    throw std::invalid_argument("NARX training: finite-difference step h must be > 0, got " + std::to_string(h));
  }
  Buffers b = weighted_buffers(model, u, skip, weights, "estimation");
  b.init = init;
  Eigen::VectorXd g(model.net.parameter_count());
  mode_gradient(model, u, y, mode, skip, h, b, g);
  return g;
}

Eigen::MatrixXd gauss_newton_hessian(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                     TrainingMode mode, Eigen::Index skip, const Eigen::VectorXd& weights,
                                     Eigen::Index init) {
  require_model(model);
  require_data(u, y, skip, "estimation");
  require_init(init, skip);
  require_single_record(mode);
  Buffers b = weighted_buffers(model, u, skip, weights, "estimation");
  b.init = init;
  const Eigen::Index P = model.net.parameter_count();
  Eigen::VectorXd g(P);
  Eigen::MatrixXd H(P, P);
  if (mode == TrainingMode::oem_n) {
    numerical_normal_equations(model, u, y, skip, kFiniteDifferenceStep, b, g, H);
  } else {
    gradient_sweep(model, u, y, mode, skip, b, g, &H);
  }
  return H;
}

TrainingResult train_narx(const NarxModel& initial, const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est,
                          const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, const TrainingOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  require_options(options);
  require_model(initial);
  const NarxStructure& s = initial.structure;
  const Eigen::Index skip =
      std::max(options.transient_skip >= 0 ? options.transient_skip : 2 * (s.na + s.nb), options.init);
  const Eigen::Index P = initial.net.parameter_count();
  require_data(u_est, y_est, skip, "estimation");
  if (u_est.size() - skip <= P) {
    throw std::invalid_argument("NARX training: " + std::to_string(u_est.size()) +
                                " estimation samples are too few: after the transient skip of " + std::to_string(skip) +
                                " the loss needs more samples than the " + std::to_string(P) +
                                " parameters, i.e. N > " + std::to_string(skip + P));
  }
  if (y_est.tail(u_est.size() - skip).squaredNorm() == 0.0) {
    throw std::invalid_argument("NARX training: the estimation output is zero after the transient skip");
  }
  const bool has_validation = u_val.size() > 0 || y_val.size() > 0;
  if (has_validation) {
    require_data(u_val, y_val, skip, "validation");
    if (y_val.tail(u_val.size() - skip).squaredNorm() == 0.0) {
      throw std::invalid_argument("NARX training: the validation output is zero after the transient skip");
    }
  }

  if (options.validation_weights.size() != 0 && !has_validation) {
    throw std::invalid_argument("NARX training: validation weights given without validation data");
  }
  if (options.mask.size() != 0) {
    if (options.mask.size() != P) {
      throw std::invalid_argument("NARX training: mask has " + std::to_string(options.mask.size()) +
                                  " entries, the network " + std::to_string(P) + " parameters");
    }
    for (Eigen::Index p = 0; p < P; ++p) {
      if (options.mask[p] != 0.0 && options.mask[p] != 1.0) {
        throw std::invalid_argument("NARX training: mask entry " + std::to_string(p) + " is " +
                                    std::to_string(options.mask[p]) + " (expected 0 = pruned or 1 = free)");
      }
    }
  }

  if (std::find(options.modes.begin(), options.modes.end(), TrainingMode::oem_ms) != options.modes.end()) {
    require_multiple_shooting_options(options.multiple_shooting, s.na);
    if (u_est.size() - skip < options.multiple_shooting.window) {
      throw std::invalid_argument("NARX training: oem-ms needs a window of " +
                                  std::to_string(options.multiple_shooting.window) +
                                  " samples after the transient skip of " + std::to_string(skip) +
                                  "; the estimation data has " + std::to_string(u_est.size()));
    }
  }
  Trainer trainer(initial, u_est, y_est, u_val, y_val, skip, options);
  NarxModel current = initial;
  if (options.mask.size() != 0) current.net.parameters().array() *= options.mask.array();  // pruned: exactly 0
  TrainingResult result{initial, {}, 0, 0.0};
  const bool keep_best = options.early_stopping && has_validation;

  auto report = [&](TrainingRecord r) {
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    result.history.push_back(r);
    if (options.progress) options.progress(r);
  };
  report(trainer.record(current, 0, options.modes.front()));
  double best_val = result.history.front().j_val_weighted_pct;
  Eigen::VectorXd best_theta = current.net.parameters();

  int iteration = 0;
  int handed_on = 0;  // iterations the pem mode left to the next mode (pem_min_progress)
  // Each mode in turn ([5N]'s loss, [5O]'s gradient): iterations of LM, the line search or [5C]'s passes,
  // stopped early on the validation J (fig. 6.4)
  for (const TrainingMode mode : options.modes) {
    trainer.lm.reset();               // LM damping λ back to its start for each mode
    if (mode == TrainingMode::oem_ms) trainer.start_shooting(current);
    double t = 0.5 * options.step;    // line search: the first trial step is α
    int without_improvement = 0;
    // Patience counts against this mode's own best: a refinement (oem-d after pem) often has to climb back
    // to the previous mode's best J_val before it improves on it, and is not cut off for that.
    double mode_best = std::numeric_limits<double>::infinity();
    const int limit = mode == TrainingMode::pem && options.pem_max_iterations >= 0 ? options.pem_max_iterations
                                                                                   : options.max_iterations + handed_on;
    handed_on = 0;
    std::vector<double> mode_bests;  // the mode's best J_val after each of its iterations
    for (int i = 0; i < limit; ++i) {
      const Eigen::VectorXd before = current.net.parameters();
      bool moved = false;
      switch (options.optimizer) {
        case Optimizer::lm: moved = trainer.lm_step(current, mode); break;
        case Optimizer::linesearch: moved = trainer.linesearch_step(current, mode, t); break;
        case Optimizer::sd: moved = trainer.sd_pass(current, mode); break;
      }
      if (!moved) {  // converged (LM, line search) or diverged (sd): keep the last good parameters
        current.net.parameters() = before;
        break;
      }
      const TrainingRecord r = trainer.record(current, ++iteration, mode);
      if (!std::isfinite(r.j_est_pct)) {
        current.net.parameters() = before;
        --iteration;
        break;
      }
      report(r);
      if (!keep_best) continue;
      // fig. 6.4: keep the best validation J; stop the mode when its J_val has not improved for `patience`
      // iterations
      if (r.j_val_weighted_pct < best_val) {
        best_val = r.j_val_weighted_pct;
        best_theta = current.net.parameters();
      }
      if (r.j_val_weighted_pct < mode_best) {
        mode_best = r.j_val_weighted_pct;
        without_improvement = 0;
      } else if (++without_improvement >= options.patience) {
        break;
      }
      // PEM is the warm start: once its best J_val has fallen by less than pem_min_progress over the last
      // kPemProgressWindow iterations, the output-error mode that follows spends the rest of its iterations better
      mode_bests.push_back(mode_best);
      const auto window = static_cast<std::size_t>(kPemProgressWindow);
      if (mode == TrainingMode::pem && options.pem_min_progress > 0.0 && mode_bests.size() > window &&
          mode_best > (1.0 - options.pem_min_progress) * mode_bests[mode_bests.size() - 1 - window]) {
        handed_on = limit - (i + 1);
        break;
      }
    }
    if (keep_best) current.net.parameters() = best_theta;  // the next mode starts from the kept parameters
  }

  result.model = std::move(current);
  result.iterations = iteration;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return result;
}

}  // namespace panelbass::models

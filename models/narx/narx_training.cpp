// NARX training. Choices beyond the header:
// - OEM simulations start from rest (ŷ and dŷ/dθ before the record are 0), so [5L] is the exact
//   gradient of the simulation loss from the first sample; `skip` only leaves the transient out of V.
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

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

/// ψ columns are gathered into a P×B block before one update H += Ψ·Ψᵀ (a GEMM instead of B rank-1
/// updates). B keeps the block under 96 kB so that Eigen's GEMM packs it on the stack: no allocation
/// per block (for P beyond ~3000 the smallest block exceeds that; such nets are not trained with LM).
Eigen::Index block_columns(Eigen::Index parameters) {
  constexpr Eigen::Index kBlockBytes = 96 * 1024;
  return std::clamp<Eigen::Index>(kBlockBytes / (static_cast<Eigen::Index>(sizeof(double)) * parameters), 4, 64);
}

/// Where the past outputs in the regressor come from ([5H]).
enum class Feedback {
  measured,   ///< PEM: y_t(k−1..k−na)
  simulated,  ///< OEM: ŷ(k−1..k−na)
};

Feedback feedback_of(TrainingMode mode) { return mode == TrainingMode::pem ? Feedback::measured : Feedback::simulated; }

/// Everything a sweep over the data writes to, sized once so that the per-sample loops never allocate.
struct Buffers {
  Mlp::Workspace ws;
  Eigen::VectorXd x;       ///< the regressor x(k)
  Eigen::VectorXd dtheta;  ///< ∂F/∂θ at sample k
  Eigen::VectorXd dx;      ///< ∂F/∂x at sample k (first na entries: ∂F/∂ŷ(k−t))
  Eigen::VectorXd none;    ///< empty: backward() skips ∂F/∂x
  Eigen::VectorXd psi;     ///< dŷ(k)/dθ
  Eigen::VectorXd yhat;    ///< the model output of the last sweep
  Eigen::MatrixXd ring;    ///< P×na: dŷ(j)/dθ of the last na samples, ψ(j) in column j mod na
  Eigen::MatrixXd block;   ///< P×B: ψ(k) waiting for H += Ψ·Ψᵀ
  Eigen::VectorXd grad;    ///< accumulator for a batch gradient (sd)
  Eigen::VectorXd weight;  ///< w(k) of the loss, as given (empty = 1 everywhere)
  double weight_total = 0; ///< Σ_{k≥skip} w(k): the loss's normaliser (N − skip without weights)

  /// The weight of sample k's squared error.
  double w(Eigen::Index k) const { return weight.size() == 0 ? 1.0 : weight[k]; }

  /// Sets the weights (empty = 1) and their total over k ≥ skip for `samples` samples.
  void set_weights(const Eigen::VectorXd& weights, Eigen::Index samples, Eigen::Index skip) {
    weight = weights;
    weight_total = weights.size() == 0 ? static_cast<double>(samples - skip) : weights.tail(samples - skip).sum();
  }

  Buffers(const NarxModel& model, Eigen::Index samples) {
    const Eigen::Index P = model.net.parameter_count();
    ws = model.net.workspace();
    x.resize(model.net.inputs());
    dtheta.resize(P);
    dx.resize(model.net.inputs());
    psi.resize(P);
    yhat.resize(samples);
    ring.resize(P, std::max(model.structure.na, 0));
    block.resize(P, block_columns(P));
    grad.resize(P);
  }
};

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

// ----- sweeps over the data ----------------------------------------------------------------------

/// V = 1/(2·Σw)·Σ_{k≥skip} w(k)·e(k)² (w = 1: 1/(2(N−skip))·Σ e(k)²), with the outputs left in b.yhat
/// ([5N]; [5H] for the feedback).
double output_loss(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Feedback feedback,
                   Eigen::Index skip, Buffers& b) {
  const Eigen::Index N = u.size();
  const Eigen::VectorXd& past = feedback == Feedback::measured ? y : b.yhat;
  double sum = 0.0;
  // [5H] PEM: ŷ(k) = F(y_t(k−1..), u(k..), θ); OEM: ŷ(k) = F(ŷ(k−1..), u(k..), θ)
  for (Eigen::Index k = 0; k < N; ++k) {
    model.regressor(u, past, k, b.x);
    const double yk = model.net.forward(b.x, b.ws);
    b.yhat[k] = yk;
    if (k >= skip) {
      const double e = yk - y[k];
      sum += b.w(k) * e * e;
    }
  }
  return 0.5 * sum / b.weight_total;
}

/// Computes ψ(k) = dŷ(k)/dθ into b.psi after forward()/backward() at sample k, for `mode`, and returns
/// a reference to it. The ring b.ring must hold ψ(k−1..k−na) for oem_d.
const Eigen::VectorXd& sensitivity(TrainingMode mode, int na, Eigen::Index k, Buffers& b) {
  if (mode != TrainingMode::oem_d || na == 0) return b.dtheta;  // [5K] (and oem_s's approximation)
  // [5L] dŷ(k)/dθ = ∂F/∂θ + Σ_{t=1}^{na} ∂F/∂ŷ(k−t)·dŷ(k−t)/dθ
  b.psi = b.dtheta;
  for (int t = 1; t <= na && k - t >= 0; ++t) b.psi.noalias() += b.dx[t - 1] * b.ring.col((k - t) % na);
  b.ring.col(k % na) = b.psi;
  return b.psi;
}

/// One sweep: V, g = dV/dθ = 1/Σw·Σ_{k≥skip} w(k)·e(k)·ψ(k) ([5M], w = 1: Σw = N − skip) and, if H is
/// given, the Gauss–Newton matrix H = 1/Σw·Σ w(k)·ψ(k)ψ(k)ᵀ (P×P, accumulated in blocks of √w·ψ columns).
double gradient_sweep(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y, TrainingMode mode,
                      Eigen::Index skip, Buffers& b, Eigen::VectorXd& g, Eigen::MatrixXd* H) {
  const Eigen::Index N = u.size();
  const int na = model.structure.na;
  const bool dynamic = mode == TrainingMode::oem_d && na > 0;
  const Eigen::VectorXd& past = mode == TrainingMode::pem ? y : b.yhat;
  g.setZero();
  if (H != nullptr) H->setZero();
  if (dynamic) b.ring.setZero();  // dŷ/dθ before the record: 0 (the start of [5L])
  Eigen::Index in_block = 0;
  double sum = 0.0;
  // [5M] dV/dθ = 1/(N−skip)·Σ_{k≥skip} e(k)·dŷ(k)/dθ, with dŷ/dθ from [5K] (pem, oem_s) or [5L] (oem_d)
  for (Eigen::Index k = 0; k < N; ++k) {
    model.regressor(u, past, k, b.x);
    const double yk = model.net.forward(b.x, b.ws);
    b.yhat[k] = yk;
    model.net.backward(b.ws, b.dtheta, dynamic ? b.dx : b.none);
    const Eigen::VectorXd& psi = sensitivity(mode, na, k, b);
    if (k < skip) continue;  // [5M] the sum starts at skip
    const double e = yk - y[k], wk = b.w(k);
    sum += wk * e * e;
    g.noalias() += (wk * e) * psi;
    if (H != nullptr) {
      b.block.col(in_block++) = std::sqrt(wk) * psi;
      if (in_block == b.block.cols()) {
        H->selfadjointView<Eigen::Lower>().rankUpdate(b.block);
        in_block = 0;
      }
    }
  }
  const double M = b.weight_total;
  if (H != nullptr) {
    if (in_block > 0) H->selfadjointView<Eigen::Lower>().rankUpdate(b.block.leftCols(in_block));
    H->triangularView<Eigen::StrictlyUpper>() = H->transpose();
    *H /= M;
  }
  g /= M;
  return 0.5 * sum / M;
}

/// dV/dθ of the simulation loss by central differences: (V(θ + h·e_p) − V(θ − h·e_p)) / 2h, 2P simulations.
void numerical_gradient(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                        Eigen::Index skip, double h, Buffers& b, Eigen::VectorXd& g) {
  NarxModel probe = model;
  Eigen::VectorXd& theta = probe.net.parameters();
  for (Eigen::Index p = 0; p < theta.size(); ++p) {
    const double keep = theta[p];
    theta[p] = keep + h;
    const double plus = output_loss(probe, u, y, Feedback::simulated, skip, b);
    theta[p] = keep - h;
    const double minus = output_loss(probe, u, y, Feedback::simulated, skip, b);
    theta[p] = keep;
    g[p] = (plus - minus) / (2.0 * h);
  }
}

/// For oem_n with LM: the numerical Jacobian of the simulated output, column p = (ŷ(θ + h·e_p) −
/// ŷ(θ − h·e_p)) / 2h over k ≥ skip. It is stored whole ((N−skip)×P), so this is for small nets only.
double numerical_normal_equations(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                  Eigen::Index skip, double h, Buffers& b, Eigen::VectorXd& g, Eigen::MatrixXd& H) {
  const Eigen::Index N = u.size(), M = N - skip;
  const double V = output_loss(model, u, y, Feedback::simulated, skip, b);
  const Eigen::VectorXd sqrt_w =
      b.weight.size() == 0 ? Eigen::VectorXd::Ones(M) : Eigen::VectorXd(b.weight.tail(M).cwiseSqrt());
  const Eigen::VectorXd e = (b.yhat.tail(M) - y.tail(M)).cwiseProduct(sqrt_w);
  NarxModel probe = model;
  Eigen::VectorXd& theta = probe.net.parameters();
  Eigen::MatrixXd jac(M, theta.size());
  for (Eigen::Index p = 0; p < theta.size(); ++p) {
    const double keep = theta[p];
    theta[p] = keep + h;
    output_loss(probe, u, y, Feedback::simulated, skip, b);
    jac.col(p) = b.yhat.tail(M);
    theta[p] = keep - h;
    output_loss(probe, u, y, Feedback::simulated, skip, b);
    jac.col(p) -= b.yhat.tail(M);
    jac.col(p) = jac.col(p).cwiseProduct(sqrt_w) / (2.0 * h);  // √w(k)·dŷ(k)/dθ_p
    theta[p] = keep;
  }
  g.noalias() = jac.transpose() * e / b.weight_total;
  H.setZero();
  H.selfadjointView<Eigen::Lower>().rankUpdate(jac.transpose(), 1.0 / b.weight_total);
  H.triangularView<Eigen::StrictlyUpper>() = H.transpose();
  return V;
}

/// dV/dθ for `mode` into g (oem_n: central differences with step h); returns V.
double mode_gradient(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y, TrainingMode mode,
                     Eigen::Index skip, double h, Buffers& b, Eigen::VectorXd& g) {
  if (mode == TrainingMode::oem_n) {
    numerical_gradient(model, u, y, skip, h, b, g);
    return output_loss(model, u, y, Feedback::simulated, skip, b);
  }
  return gradient_sweep(model, u, y, mode, skip, b, g, nullptr);
}

// ----- training ----------------------------------------------------------------------------------

/// Step for the numerical gradient and Jacobian in training (central differences).
constexpr double kFiniteDifferenceStep = 1e-6;

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
  bool has_validation;
  const TrainingOptions& options;
  Buffers est;
  Buffers val;
  NarxModel trial;          ///< a copy whose θ is overwritten by candidate steps
  Eigen::VectorXd g;
  Eigen::MatrixXd H;
  Eigen::MatrixXd A;        ///< H + λ·diag(H): the LM system matrix
  Eigen::VectorXd delta;
  Eigen::LDLT<Eigen::MatrixXd> ldlt;

  Trainer(const NarxModel& model, const Eigen::VectorXd& ue, const Eigen::VectorXd& ye, const Eigen::VectorXd& uv,
          const Eigen::VectorXd& yv, Eigen::Index skip_, const TrainingOptions& opt)
      : u_est(ue), y_est(ye), u_val(uv), y_val(yv), skip(skip_), has_validation(uv.size() > 0), options(opt),
        est(weighted_buffers(model, ue, skip_, opt.weights, "estimation")),
        val(weighted_buffers(model, uv, has_validation ? skip_ : 0, has_validation ? opt.validation_weights : Eigen::VectorXd(),
                             "validation")),
        trial(model),
        // Sized in place: copy-assigning a fresh LDLT would copy its not-yet-set ComputationInfo.
        ldlt(opt.optimizer == Optimizer::lm ? model.net.parameter_count() : 0) {
    const Eigen::Index P = model.net.parameter_count();
    g.resize(P);
    if (opt.optimizer == Optimizer::lm) {
      H.resize(P, P);
      A.resize(P, P);
    }
    delta.resize(P);
  }

  double loss(const NarxModel& m, TrainingMode mode) {
    return output_loss(m, u_est, y_est, feedback_of(mode), skip, est);
  }

  /// [2A] simulation J in percent over k ≥ skip; +∞ for a non-finite simulation. With `weighted` and
  /// weights in b: Σ w·e² / Σ w·y² instead (the figure the weighted loss minimises).
  double j_sim(const NarxModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Buffers& b,
               bool weighted = false) {
    const double V = output_loss(m, u, y, Feedback::simulated, skip, b);
    if (!b.yhat.allFinite()) return std::numeric_limits<double>::infinity();
    if (!weighted || b.weight.size() == 0) return j_percent(b.yhat, y, skip);
    const Eigen::Index M = y.size() - skip;
    const double energy = b.weight.tail(M).dot(y.tail(M).cwiseAbs2());
    return energy > 0.0 ? 100.0 * 2.0 * V * b.weight_total / energy : std::numeric_limits<double>::infinity();
  }

  TrainingRecord record(const NarxModel& m, int iteration, TrainingMode mode) {
    TrainingRecord r;
    r.iteration = iteration;
    r.mode = mode;
    r.j_est_pct = j_sim(m, u_est, y_est, est);
    r.j_val_pct = has_validation ? j_sim(m, u_val, y_val, val) : std::numeric_limits<double>::quiet_NaN();
    r.j_val_weighted_pct = val.weight.size() == 0 ? r.j_val_pct : j_sim(m, u_val, y_val, val, true);
    return r;
  }

  /// Levenberg–Marquardt: (H + λ·diag(H)) δ = g, θ ← θ − δ if V decreases; λ ÷10 on success, ×10 on failure.
  bool lm_step(NarxModel& m, TrainingMode mode, double& lambda) {
    double V;
    if (mode == TrainingMode::oem_n) {
      V = numerical_normal_equations(m, u_est, y_est, skip, kFiniteDifferenceStep, est, g, H);
    } else {
      // oem_s: the static Jacobian ∂F/∂θ with the simulation loss (the approximation of table 5.1)
      V = gradient_sweep(m, u_est, y_est, mode, skip, est, g, &H);
    }
    if (!std::isfinite(V) || !g.allFinite() || !H.allFinite()) return false;
    apply_mask(options.mask, g, &H);  // the reduced system over the free parameters
    const Eigen::VectorXd& theta = m.net.parameters();
    const double floor = 1e-9 * std::max(H.diagonal().mean(), 1e-300);
    constexpr int kRetries = 12;
    for (int attempt = 0; attempt < kRetries; ++attempt) {
      A = H;
      A.diagonal().array() += lambda * (H.diagonal().array() + floor) + 1e-12 * (1.0 + H.diagonal().maxCoeff());
      ldlt.compute(A);
      delta = ldlt.solve(g);
      if (options.mask.size() != 0) delta.array() *= options.mask.array();  // exactly 0 where pruned
      trial.net.parameters() = theta - delta;
      const double V_new = delta.allFinite() ? loss(trial, mode) : std::numeric_limits<double>::infinity();
      if (std::isfinite(V_new) && V_new < V) {
        m.net.parameters() = trial.net.parameters();
        lambda = std::max(lambda / 10.0, 1e-12);
        return true;
      }
      lambda = std::min(lambda * 10.0, 1e12);
    }
    return false;  // no decrease within the retries: a (local) minimum for this mode's Jacobian
  }

  /// Steepest descent along −dV/dθ with backtracking until Armijo's condition V(θ − t·g) ≤ V − c·t·‖g‖² holds.
  bool linesearch_step(NarxModel& m, TrainingMode mode, double& t) {
    const double V = mode_gradient(m, u_est, y_est, mode, skip, kFiniteDifferenceStep, est, g);
    apply_mask(options.mask, g, nullptr);
    const double slope = g.squaredNorm();
    if (!std::isfinite(V) || !std::isfinite(slope) || slope == 0.0) return false;
    constexpr double kArmijo = 1e-4;
    constexpr int kHalvings = 40;
    t *= 2.0;
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
      theta.noalias() -= alpha * g;
      return theta.allFinite();
    }
    const Eigen::Index N = u_est.size();
    const Eigen::Index L = options.batch == 0 ? N - skip : options.batch;
    const int na = m.structure.na;
    const bool dynamic = mode == TrainingMode::oem_d && na > 0;
    Buffers& b = est;
    const Eigen::VectorXd& past = mode == TrainingMode::pem ? y_est : b.yhat;
    if (dynamic) b.ring.setZero();
    b.grad.setZero();
    Eigen::Index in_batch = 0;
    double batch_weight = 0.0;
    for (Eigen::Index k = 0; k < N; ++k) {
      m.regressor(u_est, past, k, b.x);
      const double yk = m.net.forward(b.x, b.ws);
      b.yhat[k] = yk;
      m.net.backward(b.ws, b.dtheta, dynamic ? b.dx : b.none);
      const Eigen::VectorXd& psi = sensitivity(mode, na, k, b);
      if (k < skip) continue;
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
    }
    apply_mask(options.mask, b.grad, nullptr);
    if (in_batch > 0 && batch_weight > 0.0) theta.noalias() -= (alpha / batch_weight) * b.grad;
    return theta.allFinite();
  }
};

void require_options(const TrainingOptions& o) {
  if (o.modes.empty()) throw std::invalid_argument("NARX training: no training mode given");
  if (o.max_iterations < 0) {
    throw std::invalid_argument("NARX training: max_iterations must be ≥ 0, got " + std::to_string(o.max_iterations));
  }
  if (o.optimizer == Optimizer::sd || o.optimizer == Optimizer::linesearch) {
    if (!(o.step > 0.0) || !std::isfinite(o.step)) {
      throw std::invalid_argument("NARX training: step α must be a finite number > 0, got " + std::to_string(o.step));
    }
  }
  if (o.batch < 0) throw std::invalid_argument("NARX training: batch must be ≥ 0 (0 = all samples)");
  if (o.transient_skip < -1) {
    throw std::invalid_argument("NARX training: transient_skip must be ≥ 0 or −1 (= 2·(na + nb))");
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
  throw std::invalid_argument("unknown training mode \"" + name + "\" (expected pem, oem-s, oem-d or oem-n)");
}

std::string to_string(TrainingMode mode) {
  switch (mode) {
    case TrainingMode::pem: return "pem";
    case TrainingMode::oem_s: return "oem-s";
    case TrainingMode::oem_d: return "oem-d";
    case TrainingMode::oem_n: return "oem-n";
  }
  return "?";
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
                     Eigen::Index skip, const Eigen::VectorXd& weights) {
  require_model(model);
  require_data(u, y, skip, "estimation");
  Buffers b = weighted_buffers(model, u, skip, weights, "estimation");
  return output_loss(model, u, y, feedback_of(mode), skip, b);
}

Eigen::VectorXd loss_gradient(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                              TrainingMode mode, Eigen::Index skip, double h, const Eigen::VectorXd& weights) {
  require_model(model);
  require_data(u, y, skip, "estimation");
  if (mode == TrainingMode::oem_n && !(h > 0.0 && std::isfinite(h))) {
    throw std::invalid_argument("NARX training: finite-difference step h must be > 0, got " + std::to_string(h));
  }
  Buffers b = weighted_buffers(model, u, skip, weights, "estimation");
  Eigen::VectorXd g(model.net.parameter_count());
  mode_gradient(model, u, y, mode, skip, h, b, g);
  return g;
}

Eigen::MatrixXd gauss_newton_hessian(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                     TrainingMode mode, Eigen::Index skip, const Eigen::VectorXd& weights) {
  require_model(model);
  require_data(u, y, skip, "estimation");
  Buffers b = weighted_buffers(model, u, skip, weights, "estimation");
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
  const Eigen::Index skip = options.transient_skip >= 0 ? options.transient_skip : 2 * (s.na + s.nb);
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

  Trainer trainer(initial, u_est, y_est, u_val, y_val, skip, options);
  NarxModel current = initial;
  if (options.mask.size() != 0) current.net.parameters().array() *= options.mask.array();  // pruned: exactly 0
  TrainingResult result{initial, {}, 0, 0.0};
  const bool keep_best = options.early_stopping && has_validation;

  auto report = [&](const TrainingRecord& r) {
    result.history.push_back(r);
    if (options.progress) options.progress(r);
  };
  report(trainer.record(current, 0, options.modes.front()));
  double best_val = result.history.front().j_val_weighted_pct;
  Eigen::VectorXd best_theta = current.net.parameters();

  int iteration = 0;
  for (const TrainingMode mode : options.modes) {
    double lambda = 1e-3;             // LM damping, reset per mode
    double t = 0.5 * options.step;    // line search: the first trial step is α
    int without_improvement = 0;
    for (int i = 0; i < options.max_iterations; ++i) {
      const Eigen::VectorXd before = current.net.parameters();
      bool moved = false;
      switch (options.optimizer) {
        case Optimizer::lm: moved = trainer.lm_step(current, mode, lambda); break;
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
      // fig. 6.4: stop when the validation J has not improved for `patience` iterations
      if (r.j_val_weighted_pct < best_val) {
        best_val = r.j_val_weighted_pct;
        best_theta = current.net.parameters();
        without_improvement = 0;
      } else if (++without_improvement >= options.patience) {
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

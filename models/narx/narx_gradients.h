#pragma once
// The sweeps over a record that NARX training is built from (thesis ch. 5): the model output with past
// outputs measured or simulated ([5H]), its sensitivities dŷ/dθ ([5K] static, [5L] through the fed-back
// outputs), the loss and its gradient ([5M]), the Gauss–Newton matrix accumulated blockwise, and their
// central-difference counterparts for oem-n. Used by narx_training; scaled data, no checks (the driver's).

#include <Eigen/Core>
#include <algorithm>

#include "models/narx/narx_model.h"
#include "models/narx/narx_training.h"

namespace panelbass::models::narx {

/// Step for the numerical gradient and Jacobian in training (central differences).
constexpr double kFiniteDifferenceStep = 1e-6;

/// Where the past outputs in the regressor come from ([5H]).
enum class Feedback {
  measured,   ///< PEM: y_t(k−1..k−na)
  simulated,  ///< OEM: ŷ(k−1..k−na)
};

/// The feedback `mode` runs with: measured for pem, simulated for the oem modes.
inline Feedback feedback_of(TrainingMode mode) {
  return mode == TrainingMode::pem ? Feedback::measured : Feedback::simulated;
}

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
  Eigen::Index init = 0;   ///< simulations take the measured y(k) as ŷ(k) for k < init (as validate --init)

  /// Sized for `model` on `samples` samples, weights 1 (set_weights before a sweep).
  Buffers(const NarxModel& model, Eigen::Index samples);

  /// The weight of sample k's squared error.
  double w(Eigen::Index k) const { return weight.size() == 0 ? 1.0 : weight[k]; }

  /// Sets the weights (empty = 1) and their total over k ≥ skip for `samples` samples.
  void set_weights(const Eigen::VectorXd& weights, Eigen::Index samples, Eigen::Index skip);
};

/// V = 1/(2·Σw)·Σ_{k≥skip} w(k)·e(k)² (w = 1: 1/(2(N−skip))·Σ e(k)²), with the outputs left in b.yhat
/// ([5N]; [5H] for the feedback). A simulation takes ŷ(k) = y(k) for k < b.init (skip ≥ b.init).
double output_loss(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Feedback feedback,
                   Eigen::Index skip, Buffers& b);

/// Computes ψ(k) = dŷ(k)/dθ into b.psi after forward()/backward() at sample k, for `mode`, and returns
/// a reference to it. The ring b.ring must hold ψ(k−1..k−na) for oem_d.
/// (Inline: it runs once per sample inside every sweep.)
inline const Eigen::VectorXd& sensitivity(TrainingMode mode, int na, Eigen::Index k, Buffers& b) {
  if (mode != TrainingMode::oem_d || na == 0) return b.dtheta;  // [5K] (and oem_s's approximation)
  // [5L] dŷ(k)/dθ = ∂F/∂θ + Σ_{t=1}^{na} ∂F/∂ŷ(k−t)·dŷ(k−t)/dθ
  // ([5O]'s dynamic gradient; its static one is [5K])
  b.psi = b.dtheta;
  for (int t = 1; t <= na && k - t >= 0; ++t) b.psi.noalias() += b.dx[t - 1] * b.ring.col((k - t) % na);
  b.ring.col(k % na) = b.psi;
  return b.psi;
}

/// The model output over the record with its sensitivity, sample by sample: ŷ(k) into b.yhat ([5H]: past
/// outputs measured for pem, simulated otherwise), ψ(k) = dŷ(k)/dθ ([5K] for pem and oem_s, [5L] for
/// oem_d, from rest or, for k < b.init, ŷ(k) = y(k) with ψ(k) = 0: the state set by measured outputs), and
/// at_sample(k, ŷ(k), ψ(k)) for each k ≥ skip ([5M]'s sum starts there; skip ≥ b.init). at_sample may
/// change the model's θ (steepest descent within a pass): later samples use the new θ.
template <class AtSample>
void sweep_sensitivities(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                         TrainingMode mode, Eigen::Index skip, Buffers& b, AtSample&& at_sample) {
  const Eigen::Index N = u.size();
  const int na = model.structure.na;
  const bool dynamic = mode == TrainingMode::oem_d && na > 0;
  const Eigen::VectorXd& past = mode == TrainingMode::pem ? y : b.yhat;
  if (dynamic) b.ring.setZero();  // dŷ/dθ before the record and over the measured start: 0 (the start of [5L])
  const Eigen::Index init = mode == TrainingMode::pem ? 0 : std::min(b.init, N);
  b.yhat.head(init) = y.head(init);  // the state from measured outputs: ŷ(k) = y(k), independent of θ
  // [5H] ŷ(k) = F(past outputs, u(k..), θ), then [5K]/[5L] dŷ(k)/dθ
  for (Eigen::Index k = init; k < N; ++k) {
    model.regressor(u, past, k, b.x);
    const double yk = model.net.forward(b.x, b.ws);
    b.yhat[k] = yk;
    model.net.backward(b.ws, b.dtheta, dynamic ? b.dx : b.none);
    const Eigen::VectorXd& psi = sensitivity(mode, na, k, b);
    if (k < skip) continue;  // [5M] the sum starts at skip
    at_sample(k, yk, psi);
  }
}

/// One sweep: V, g = dV/dθ = 1/Σw·Σ_{k≥skip} w(k)·e(k)·ψ(k) ([5M], w = 1: Σw = N − skip) and, if H is
/// given, the Gauss–Newton matrix H = 1/Σw·Σ w(k)·ψ(k)ψ(k)ᵀ (P×P, accumulated in blocks of √w·ψ columns).
double gradient_sweep(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y, TrainingMode mode,
                      Eigen::Index skip, Buffers& b, Eigen::VectorXd& g, Eigen::MatrixXd* H);

/// dV/dθ of the simulation loss by central differences: (V(θ + h·e_p) − V(θ − h·e_p)) / 2h, 2P simulations.
void numerical_gradient(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                        Eigen::Index skip, double h, Buffers& b, Eigen::VectorXd& g);

/// For oem_n with LM: V, g and H from the numerical Jacobian of the simulated output, column p =
/// (ŷ(θ + h·e_p) − ŷ(θ − h·e_p)) / 2h over k ≥ skip. It is stored whole ((N−skip)×P), so this is for
/// small nets only.
double numerical_normal_equations(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                  Eigen::Index skip, double h, Buffers& b, Eigen::VectorXd& g, Eigen::MatrixXd& H);

/// dV/dθ for `mode` into g (oem_n: central differences with step h); returns V.
double mode_gradient(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y, TrainingMode mode,
                     Eigen::Index skip, double h, Buffers& b, Eigen::VectorXd& g);

}  // namespace panelbass::models::narx

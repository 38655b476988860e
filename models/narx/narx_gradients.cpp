// NARX sweeps. Choices beyond the header:
// - OEM simulations start from rest (ŷ and dŷ/dθ before the record are 0), or with Buffers::init from
//   measured outputs (ŷ(k) = y(k), dŷ(k)/dθ = 0 for k < init); either way [5L] is the exact gradient of
//   the simulation loss; `skip` (≥ init) only leaves the transient out of V.
// - oem_n: the numerical Jacobian is formed column by column (2P simulations, stored (N−skip)×P).
#include "models/narx/narx_gradients.h"

#include <algorithm>
#include <cmath>

namespace panelbass::models::narx {
namespace {

/// ψ columns are gathered into a P×B block before one update H += Ψ·Ψᵀ (a GEMM instead of B rank-1
/// updates). B keeps the block under 96 kB so that Eigen's GEMM packs it on the stack: no allocation
/// per block (for P beyond ~3000 the smallest block exceeds that; such nets are not trained with LM).
Eigen::Index block_columns(Eigen::Index parameters) {
  constexpr Eigen::Index kBlockBytes = 96 * 1024;
  return std::clamp<Eigen::Index>(kBlockBytes / (static_cast<Eigen::Index>(sizeof(double)) * parameters), 4, 64);
}

}  // namespace

Buffers::Buffers(const NarxModel& model, Eigen::Index samples) {
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

void Buffers::set_weights(const Eigen::VectorXd& weights, Eigen::Index samples, Eigen::Index skip) {
  weight = weights;
  weight_total = weights.size() == 0 ? static_cast<double>(samples - skip) : weights.tail(samples - skip).sum();
}

double output_loss(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Feedback feedback,
                   Eigen::Index skip, Buffers& b) {
  const Eigen::Index N = u.size();
  const Eigen::VectorXd& past = feedback == Feedback::measured ? y : b.yhat;
  const Eigen::Index init = feedback == Feedback::measured ? 0 : std::min(b.init, N);
  b.yhat.head(init) = y.head(init);  // OEM: the state from measured outputs, as validate --init
  double sum = 0.0;
  // [5H] PEM: ŷ(k) = F(y_t(k−1..), u(k..), θ); OEM: ŷ(k) = F(ŷ(k−1..), u(k..), θ)
  for (Eigen::Index k = init; k < N; ++k) {
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

double gradient_sweep(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y, TrainingMode mode,
                      Eigen::Index skip, Buffers& b, Eigen::VectorXd& g, Eigen::MatrixXd* H) {
  g.setZero();
  if (H != nullptr) H->setZero();
  Eigen::Index in_block = 0;
  double sum = 0.0;
  // [5M] dV/dθ = 1/(N−skip)·Σ_{k≥skip} e(k)·dŷ(k)/dθ, with dŷ/dθ from [5K] (pem, oem_s) or [5L] (oem_d)
  sweep_sensitivities(model, u, y, mode, skip, b, [&](Eigen::Index k, double yk, const Eigen::VectorXd& psi) {
    const double e = yk - y[k], wk = b.w(k);
    sum += wk * e * e;
    g.noalias() += (wk * e) * psi;
    if (H != nullptr) {
      // H = 1/Σw·Σ w(k)·ψ(k)ψ(k)ᵀ, a block of √w·ψ columns at a time
      b.block.col(in_block++) = std::sqrt(wk) * psi;
      if (in_block == b.block.cols()) {
        H->selfadjointView<Eigen::Lower>().rankUpdate(b.block);
        in_block = 0;
      }
    }
  });
  const double M = b.weight_total;
  if (H != nullptr) {
    if (in_block > 0) H->selfadjointView<Eigen::Lower>().rankUpdate(b.block.leftCols(in_block));
    H->triangularView<Eigen::StrictlyUpper>() = H->transpose();
    *H /= M;
  }
  g /= M;
  return 0.5 * sum / M;
}

void numerical_gradient(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                        Eigen::Index skip, double h, Buffers& b, Eigen::VectorXd& g) {
  NarxModel probe = model;
  Eigen::VectorXd& theta = probe.net.parameters();
  // fig. 5.9 (oem-n): dV/dθ_p ≈ (V(θ + h·e_p) − V(θ − h·e_p)) / 2h, V the simulation loss of [5N]
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
  // fig. 5.9 applied to the output: dŷ(k)/dθ_p ≈ (ŷ(θ + h·e_p) − ŷ(θ − h·e_p)) / 2h, the [5O] sensitivity
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

double mode_gradient(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y, TrainingMode mode,
                     Eigen::Index skip, double h, Buffers& b, Eigen::VectorXd& g) {
  if (mode == TrainingMode::oem_n) {
    numerical_gradient(model, u, y, skip, h, b, g);
    return output_loss(model, u, y, Feedback::simulated, skip, b);
  }
  return gradient_sweep(model, u, y, mode, skip, b, g, nullptr);
}

}  // namespace panelbass::models::narx

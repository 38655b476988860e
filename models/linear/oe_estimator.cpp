#include "models/linear/oe_estimator.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <string>

#include "models/linear/estimation_error.h"
#include "models/optimization/levenberg_marquardt.h"

namespace panelbass::models {
namespace {

std::string oe_name(const TransferFunction& tf) {
  return "OE(na=" + std::to_string(tf.na()) + ", nb=" + std::to_string(tf.nb()) + ", nk=" + std::to_string(tf.nk) +
         ")";
}

void require_finite(const Eigen::VectorXd& x, const char* what, const std::string& name) {
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k])) {
      throw EstimationError(name + ": the " + what + " has a non-finite value at sample " + std::to_string(k));
    }
  }
}

/// ŷ = B(q)/A(q)·u from rest: ŷ(k) = Σ_j b_j·u(k−nk−j) − Σ_i a_i·ŷ(k−i).
Eigen::VectorXd simulate(const TransferFunction& tf, const Eigen::VectorXd& u) {
  const Eigen::Index N = u.size(), na = tf.na(), nb = tf.nb(), nk = tf.nk;
  Eigen::VectorXd y(N);
  for (Eigen::Index k = 0; k < N; ++k) {
    double s = 0.0;
    for (Eigen::Index j = 0; j < nb && k - nk - j >= 0; ++j) s += tf.b[j] * u[k - nk - j];
    for (Eigen::Index i = 1; i <= na && k - i >= 0; ++i) s -= tf.a[i - 1] * y[k - i];
    y[k] = s;
  }
  return y;
}

/// w = x/A(q) from rest: w(k) = x(k) − Σ_i a_i·w(k−i).
Eigen::VectorXd filter_by_inverse_a(const Eigen::VectorXd& a, const Eigen::VectorXd& x) {
  const Eigen::Index N = x.size(), na = a.size();
  Eigen::VectorXd w(N);
  for (Eigen::Index k = 0; k < N; ++k) {
    double s = x[k];
    for (Eigen::Index i = 1; i <= na && k - i >= 0; ++i) s -= a[i - 1] * w[k - i];
    w[k] = s;
  }
  return w;
}

/// Rows [skip, N) of the Jacobian of ŷ at `tf`, given ŷ itself (so it is simulated once per iteration).
Eigen::MatrixXd jacobian_rows(const Eigen::VectorXd& u, const Eigen::VectorXd& y_hat, const TransferFunction& tf,
                              Eigen::Index skip) {
  const Eigen::Index N = u.size(), na = tf.na(), nb = tf.nb(), nk = tf.nk, M = N - skip;
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(M, na + nb);
  // ∂ŷ/∂a_i = −q^(−i)/A·ŷ and ∂ŷ/∂b_j = q^(−nk−j)/A·u: two filterings through 1/A, then shifted copies.
  const Eigen::VectorXd v = filter_by_inverse_a(tf.a, y_hat);
  const Eigen::VectorXd w = filter_by_inverse_a(tf.a, u);
  auto shifted_into = [&](Eigen::Index col, const Eigen::VectorXd& x, Eigen::Index delay, double sign) {
    // J(k − skip, col) = sign·x(k − delay) for k ≥ max(skip, delay)
    const Eigen::Index k0 = std::max(skip, delay);
    if (k0 >= N) return;
    J.col(col).segment(k0 - skip, N - k0) = sign * x.segment(k0 - delay, N - k0);
  };
  for (Eigen::Index i = 1; i <= na; ++i) shifted_into(i - 1, v, i, -1.0);
  for (Eigen::Index j = 0; j < nb; ++j) shifted_into(na + j, w, nk + j, 1.0);
  return J;
}

Eigen::VectorXd theta_of(const TransferFunction& tf) {
  Eigen::VectorXd theta(tf.na() + tf.nb());
  theta << tf.a, tf.b;
  return theta;
}

TransferFunction tf_of(const Eigen::VectorXd& theta, Eigen::Index na, int nk) {
  TransferFunction tf;
  tf.a = theta.head(na);
  tf.b = theta.tail(theta.size() - na);
  tf.nk = nk;
  return tf;
}

/// V = (1/M)·Σ_{k≥skip} (y(k) − ŷ(k))², M = N − skip.
double loss_of(const Eigen::VectorXd& y, const Eigen::VectorXd& y_hat, Eigen::Index skip) {
  const Eigen::Index M = y.size() - skip;
  return (y.tail(M) - y_hat.tail(M)).squaredNorm() / static_cast<double>(M);
}

/// λ from 1e-3, ÷10 on success down to 1e-12, ×10 on failure without bound; 30 retries from 1e-12 reach 1e18.
constexpr LmSettings kLmSettings{.damping = LmDamping::relative_to_largest,
                                 .initial_lambda = 1e-3,
                                 .min_lambda = 1e-12,
                                 .retries = 30};

}  // namespace

Eigen::MatrixXd oe_jacobian(const Eigen::VectorXd& u, const TransferFunction& tf) {
  return jacobian_rows(u, simulate(tf, u), tf, 0);
}

TransferFunction stabilized(const TransferFunction& tf, double margin) {
  if (tf.na() == 0 || tf.is_stable(margin)) return tf;
  const double limit = 1.0 - margin;
  Eigen::VectorXcd p = tf.poles();
  // A pole outside the unit circle goes to 1/conj(p) (same angle, |H| shape kept up to a constant);
  // one still at or beyond the margin (on the circle, or reflected into the band) is pulled to a radius
  // a little inside it. Poles already inside are untouched.
  double target = limit * (1.0 - 1e-4);
  for (int attempt = 0; attempt < 20; ++attempt) {
    for (Eigen::Index k = 0; k < p.size(); ++k) {
      double r = std::abs(p[k]);
      if (r > 1.0) {
        p[k] = 1.0 / std::conj(p[k]);
        r = std::abs(p[k]);
      }
      if (r >= target) p[k] = (r > 0.0 ? p[k] / r : std::complex<double>(1.0)) * target;
    }
    TransferFunction out = tf;  // B unchanged
    out.a = polynomial_from_roots(p).tail(p.size());
    if (out.is_stable(margin)) return out;
    target *= 1.0 - 1e-3;  // rounding in the root round trip (repeated poles) left one outside: pull in more
  }
  throw EstimationError("stabilize: could not place the poles of an order-" + std::to_string(tf.na()) +
                        " denominator inside radius " + std::to_string(limit));
}

OeResult estimate_oe(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const TransferFunction& initial,
                     const OeOptions& options) {
  const std::string name = oe_name(initial);
  if (initial.nb() < 1) throw EstimationError(name + ": the initial model has no numerator coefficients");
  if (initial.nk < 0) throw EstimationError(name + ": the input delay must not be negative");
  if (!initial.all_finite()) throw EstimationError(name + ": the initial model has a non-finite coefficient");
  if (options.max_iterations < 0) throw EstimationError(name + ": max_iterations must not be negative");
  if (!(options.tolerance >= 0.0)) throw EstimationError(name + ": the tolerance must not be negative");
  if (!(options.stability_margin >= 0.0 && options.stability_margin < 1.0)) {
    throw EstimationError(name + ": the stability margin must lie in [0, 1)");
  }
  if (options.transient_skip < 0) throw EstimationError(name + ": the transient skip must not be negative");
  if (u.size() != y.size()) {
    throw EstimationError(name + ": the input has " + std::to_string(u.size()) + " samples but the output has " +
                          std::to_string(y.size()));
  }
  require_finite(u, "input", name);
  require_finite(y, "output", name);
  const Eigen::Index N = u.size(), na = initial.na(), P = initial.na() + initial.nb(), skip = options.transient_skip;
  if (N == 0 || u.maxCoeff() == u.minCoeff()) throw EstimationError(name + ": the input is constant");
  if (N - skip <= P) {
    throw EstimationError(name + ": " + std::to_string(std::max<Eigen::Index>(N - skip, 0)) +
                          " samples after a transient skip of " + std::to_string(skip) + " are too few for " +
                          std::to_string(P) + " parameters");
  }
  // A loss this small relative to the output's mean square is an exact fit up to rounding.
  const double exact = 1e-28 * y.tail(N - skip).squaredNorm() / static_cast<double>(N - skip);

  OeResult result;
  result.tf = stabilized(initial, options.stability_margin);
  Eigen::VectorXd theta = theta_of(result.tf);
  Eigen::VectorXd y_hat = simulate(result.tf, u);
  double loss = loss_of(y, y_hat, skip);
  result.history.push_back(loss);
  LevenbergMarquardt lm(kLmSettings, P);
  result.stop_reason = "max_iterations";
  if (loss <= exact) result.stop_reason = "converged";

  while (result.stop_reason == "max_iterations" && result.iterations < options.max_iterations) {
    // [5M] dV/dθ = −(2/M)·Σ_{k≥skip} e(k)·dŷ(k)/dθ, e = y − ŷ; dŷ/dθ exact ([5L] for a linear model:
    // the recursion through the fed-back outputs is the filter 1/A).
    const Eigen::MatrixXd J = jacobian_rows(u, y_hat, result.tf, skip);
    const Eigen::VectorXd e = y.tail(N - skip) - y_hat.tail(N - skip);
    Eigen::MatrixXd H(P, P);
    H.setZero();
    H.selfadjointView<Eigen::Lower>().rankUpdate(J.transpose());
    H.triangularView<Eigen::StrictlyUpper>() = H.transpose();
    // g = −Jᵀe = (M/2)·dV/dθ and H = ΨᵀΨ, (M/2) times V's Gauss–Newton matrix: one scaling for both. The
    // negation is exact, so θ − δ is θ + (H + λ·D)⁻¹Ψᵀe to the bit.
    const Eigen::VectorXd g = -(J.transpose() * e);

    // Levenberg–Marquardt: (ΨᵀΨ + λ·diag(ΨᵀΨ))·δ = g, the damping floored so that an identically zero
    // column (an unexcited parameter) keeps the system definite and its step zero; a candidate with a pole
    // outside the margin is rejected as if its loss were infinite.
    TransferFunction candidate;
    Eigen::VectorXd candidate_y;
    const LmStep step = lm.step(H, g, loss, theta, [&](const Eigen::VectorXd& trial) {
      candidate = tf_of(trial, na, initial.nk);
      if (!candidate.is_stable(options.stability_margin)) return std::numeric_limits<double>::infinity();
      candidate_y = simulate(candidate, u);
      return loss_of(y, candidate_y, skip);
    });
    if (step.accepted) {
      const double improvement = (loss - step.loss) / loss;
      result.tf = candidate;
      y_hat = candidate_y;
      loss = step.loss;
      ++result.iterations;
      result.history.push_back(loss);
      if (options.progress) options.progress(result.iterations, loss);
      if (improvement < options.tolerance || loss <= exact) result.stop_reason = "converged";
    } else {
      result.stop_reason = "no_descent";
    }
  }
  result.loss = loss;
  result.converged = result.stop_reason == "converged";
  return result;
}

}  // namespace panelbass::models

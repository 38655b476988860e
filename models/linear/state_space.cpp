#include "models/linear/state_space.h"

#include "models/linear/extended_precision.h"
#include "models/linear/state_space_runner.h"
#include "models/io/number_text.h"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace panelbass::models {
namespace {

// The realisation and balancing arithmetic runs in long double (extended_precision.h): a high-order
// polynomial model's companion form is badly conditioned.
using namespace extended;

// realize() drops balanced states whose Hankel singular value is below this fraction of the largest:
// they change the response by at most 2·Σσ_dropped (the balanced-truncation bound), far below double
// precision, and keeping them would make the balancing transformation singular.
constexpr Real kRealizeTruncation = 1e-15L;
// balance() calls a system non-minimal when a Hankel singular value falls below this fraction of the
// largest: such a state moves the output by less than the rounding of double-precision matrices. It
// is ten times below kRealizeTruncation, so balancing a realize() result again never fails.
constexpr Real kMinimalTolerance = 1e-16L;
// realize() accepts a balanced realisation whose response is this close to the polynomial's (relative
// to its peak); a well-conditioned 30th-order model lands near 1e-10.
constexpr double kFaithfulResponse = 1e-8;


// A square root L (L·Lᵀ = W) of a positive semidefinite W; eigenvalues that rounding made negative are
// taken as zero, so a singular Gramian gives a rank-deficient factor rather than a failure.
MatrixL psd_square_root(const MatrixL& W) {
  const Eigen::SelfAdjointEigenSolver<MatrixL> eig(W);
  const VectorL root = eig.eigenvalues().cwiseMax(0.0L).cwiseSqrt();
  return eig.eigenvectors() * root.asDiagonal();
}

// The balanced realisation by the square-root method, keeping the states whose Hankel singular value
// exceeds `tolerance`·σ₁. `A` must be stable. Returns the number of states kept in *kept.
StateSpace balance_long(const MatrixL& A, const VectorL& B, const RowVectorL& C, double D, Real tolerance,
                        Eigen::VectorXd* hankel_singular_values, Eigen::Index* kept) {
  const Eigen::Index n = A.rows();
  // Wc = A·Wc·Aᵀ + B·Bᵀ,  Wo = Aᵀ·Wo·A + Cᵀ·C
  const MatrixL Wc = solve_discrete_lyapunov(A, B * B.transpose());
  const MatrixL Wo = solve_discrete_lyapunov(A.transpose(), C.transpose() * C);
  const MatrixL Lc = psd_square_root(Wc);
  const MatrixL Lo = psd_square_root(Wo);
  // Loᵀ·Lc = U·Σ·Vᵀ: Σ holds the Hankel singular values √λ(Wc·Wo).
  const Eigen::JacobiSVD<MatrixL> svd(Lo.transpose() * Lc, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const VectorL sigma = svd.singularValues();
  if (hankel_singular_values != nullptr) *hankel_singular_values = sigma.cast<double>();

  Eigen::Index r = 0;
  while (r < n && sigma[r] > tolerance * sigma[0]) ++r;
  *kept = r;

  // T = Lc·V·Σ^(−1/2) and T⁻¹ = Σ^(−1/2)·Uᵀ·Loᵀ make both Gramians equal to Σ.
  const VectorL inv_root = sigma.head(r).cwiseSqrt().cwiseInverse();
  MatrixL T = Lc * svd.matrixV().leftCols(r) * inv_root.asDiagonal();
  MatrixL Ti = inv_root.asDiagonal() * svd.matrixU().leftCols(r).transpose() * Lo.transpose();
  // The SVD fixes each state only up to sign; choosing C ≥ 0 makes the realisation reproducible.
  RowVectorL Cb = C * T;
  for (Eigen::Index i = 0; i < r; ++i) {
    if (Cb[i] < 0.0L) {
      T.col(i) = -T.col(i);
      Ti.row(i) = -Ti.row(i);
      Cb[i] = -Cb[i];
    }
  }
  StateSpace out;
  out.A = (Ti * A * T).cast<double>();
  out.B = (Ti * B).cast<double>();
  out.C = Cb.cast<double>();
  out.D = D;
  return out;
}

// True when the balanced `ss` is stable and its response stays within kFaithfulResponse·max|H| of
// β/α (evaluated in long double) on a frequency grid and at every pole's angle, where the resonance
// peaks are. A polynomial so ill conditioned that its Gramians cannot be resolved in long double fails
// this, and realize() then keeps the canonical form, which is exactly the coefficients.
bool faithful(const StateSpace& ss, const VectorL& alpha, const VectorL& beta) {
  const Eigen::Index n = ss.order();
  Eigen::VectorXcd poles(0);
  if (n > 0) {
    poles = Eigen::EigenSolver<Eigen::MatrixXd>(ss.A, false).eigenvalues();
    if (!(poles.cwiseAbs().maxCoeff() < 1.0)) return false;
  }
  constexpr int kGrid = 64;
  std::vector<double> omegas;
  for (int i = 0; i < kGrid; ++i) omegas.push_back(std::numbers::pi * (i + 0.5) / kGrid);
  for (Eigen::Index i = 0; i < poles.size(); ++i) omegas.push_back(std::abs(std::arg(poles[i])));
  double largest = 0.0, worst = 0.0;
  for (const double omega : omegas) {
    // β(z⁻¹)/α(z⁻¹) by Horner's rule in z⁻¹
    const ComplexL z_inv = std::polar(1.0L, static_cast<Real>(-omega));
    ComplexL num = 0.0L, den = 0.0L;
    for (Eigen::Index i = beta.size() - 1; i >= 0; --i) num = num * z_inv + beta[i];
    for (Eigen::Index i = alpha.size() - 1; i >= 0; --i) den = den * z_inv + alpha[i];
    const std::complex<double> exact(num / den);
    const std::complex<double> h = response(ss, omega, 2.0 * std::numbers::pi);
    largest = std::max(largest, std::abs(exact));
    worst = std::max(worst, std::abs(h - exact));
  }
  return worst <= kFaithfulResponse * largest;
}

}  // namespace

void check_shape(const StateSpace& ss, const char* where) {
  const Eigen::Index n = ss.A.rows();
  if (ss.A.cols() != n || ss.B.size() != n || ss.C.size() != n) {
    throw std::invalid_argument(std::string(where) + ": A must be n×n and B, C of length n (A " +
                                std::to_string(ss.A.rows()) + "×" + std::to_string(ss.A.cols()) + ", B " +
                                std::to_string(ss.B.size()) + ", C " + std::to_string(ss.C.size()) + ")");
  }
}

StateSpace realize(const TransferFunction& tf) {
  if (!tf.all_finite()) throw std::invalid_argument("realize: transfer function has a non-finite coefficient");
  if (tf.nk < 0) throw std::invalid_argument("realize: negative input delay nk = " + std::to_string(tf.nk));
  // Trailing zero coefficients are no dynamics; dropping them keeps the realisation free of
  // pole–zero cancellations at the origin.
  Eigen::Index na = tf.a.size();
  while (na > 0 && tf.a[na - 1] == 0.0) --na;
  Eigen::Index nb = tf.b.size();
  while (nb > 0 && tf.b[nb - 1] == 0.0) --nb;
  StateSpace ss;
  if (nb == 0) {  // H = 0
    ss.A.resize(0, 0);
    ss.B.resize(0);
    ss.C.resize(0);
    return ss;
  }
  // H = β(q⁻¹)/α(q⁻¹) with β = q⁻ⁿᵏ·B padded and α = A, both of degree n = max(na, nk + nb − 1).
  const Eigen::Index n = std::max<Eigen::Index>(na, tf.nk + nb - 1);
  VectorL alpha = VectorL::Zero(n + 1), beta = VectorL::Zero(n + 1);
  alpha[0] = 1.0L;
  for (Eigen::Index i = 0; i < na; ++i) alpha[i + 1] = tf.a[i];
  for (Eigen::Index j = 0; j < nb; ++j) beta[tf.nk + j] = tf.b[j];
  const double D = static_cast<double>(beta[0]);

  // Observable canonical form of H − D = Σ (β_i − D·α_i) q⁻ⁱ / α(q⁻¹):
  //   x_i(k+1) = −α_i·x_1(k) + x_{i+1}(k) + (β_i − D·α_i)·u(k),  y(k) = x_1(k) + D·u(k)
  MatrixL A = MatrixL::Zero(n, n);
  VectorL B(n);
  RowVectorL C = RowVectorL::Zero(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    A(i, 0) = -alpha[i + 1];
    if (i + 1 < n) A(i, i + 1) = 1.0L;
    B[i] = beta[i + 1] - beta[0] * alpha[i + 1];
  }
  if (n > 0) C[0] = 1.0L;

  if (n > 0 && spectral_radius(A) < 1.0L) {
    Eigen::Index kept = 0;
    StateSpace balanced = balance_long(A, B, C, D, kRealizeTruncation, nullptr, &kept);
    if (faithful(balanced, alpha, beta)) return balanced;
  }
  // Unstable, static, or beyond what balancing can resolve: the canonical form is the realisation.
  ss.A = A.cast<double>();
  ss.B = B.cast<double>();
  ss.C = C.cast<double>();
  ss.D = D;
  return ss;
}

StateSpace balance(const StateSpace& ss, Eigen::VectorXd* hankel_singular_values) {
  check_shape(ss, "balance");
  if (!ss.A.allFinite() || !ss.B.allFinite() || !ss.C.allFinite() || !std::isfinite(ss.D)) {
    throw std::invalid_argument("balance: non-finite matrix entry");
  }
  const MatrixL A = ss.A.cast<Real>();
  const Real radius = spectral_radius(A);
  if (!(radius < 1.0L)) {
    throw std::invalid_argument("balance: not stable (pole radius " + number_text(static_cast<double>(radius)) + ")");
  }
  if (ss.order() == 0) {
    if (hankel_singular_values != nullptr) hankel_singular_values->resize(0);
    return ss;
  }
  Eigen::VectorXd sigma;
  Eigen::Index kept = 0;
  StateSpace out = balance_long(A, ss.B.cast<Real>(), ss.C.cast<Real>(), ss.D, kMinimalTolerance, &sigma, &kept);
  if (kept < ss.order()) {
    throw std::invalid_argument("balance: not minimal (Hankel singular value " + number_text(sigma[ss.order() - 1]) +
                                " against largest " + number_text(sigma[0]) + ": a Gramian is not positive definite)");
  }
  if (hankel_singular_values != nullptr) *hankel_singular_values = sigma;
  return out;
}

TransferFunction to_transfer_function(const StateSpace& ss) {
  check_shape(ss, "to_transfer_function");
  TransferFunction tf;
  const Eigen::Index n = ss.order();
  if (n == 0) {
    tf.a.resize(0);
    tf.b = Eigen::VectorXd::Constant(1, ss.D);
    return tf;
  }
  // C·(zI − A)⁻¹·B = [det(zI − A + B·C) − det(zI − A)] / det(zI − A), each determinant the
  // characteristic polynomial built from the eigenvalues.
  const Eigen::VectorXd den = polynomial_from_roots(Eigen::EigenSolver<Eigen::MatrixXd>(ss.A, false).eigenvalues());
  const Eigen::MatrixXd closed = ss.A - ss.B * ss.C;
  const Eigen::VectorXd shifted = polynomial_from_roots(Eigen::EigenSolver<Eigen::MatrixXd>(closed, false).eigenvalues());
  tf.a = den.tail(n);
  tf.b = shifted - den + ss.D * den;
  tf.b[0] = ss.D;  // the monic leading terms cancel exactly
  return tf;
}

Eigen::VectorXd simulate(const StateSpace& ss, const Eigen::VectorXd& u, const Eigen::VectorXd& x0) {
  check_shape(ss, "simulate");
  const Eigen::Index n = ss.order();
  if (x0.size() != 0 && x0.size() != n) {
    throw std::invalid_argument("simulate: initial state has " + std::to_string(x0.size()) + " entries, model has " +
                                std::to_string(n) + " states");
  }
  StateSpaceRunner runner(ss, x0);
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) y[k] = runner.step(u[k]);
  return y;
}

Eigen::VectorXd initial_state(const StateSpace& ss, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                              Eigen::Index samples) {
  check_shape(ss, "initial_state");
  const Eigen::Index n = ss.order();
  if (samples < n) {
    throw std::invalid_argument("initial_state: " + std::to_string(samples) + " samples cannot determine " +
                                std::to_string(n) + " states");
  }
  if (samples > u.size() || samples > y.size()) {
    throw std::invalid_argument("initial_state: " + std::to_string(samples) + " samples requested, input has " +
                                std::to_string(u.size()) + " and output " + std::to_string(y.size()));
  }
  if (n == 0) return Eigen::VectorXd(0);
  // y(k) − (forced response)(k) = C·A^k·x0 for k < samples: the free response is linear in x0.
  const Eigen::VectorXd free = y.head(samples) - simulate(ss, u.head(samples));
  Eigen::MatrixXd observability(samples, n);
  Eigen::RowVectorXd row = ss.C;
  for (Eigen::Index k = 0; k < samples; ++k) {
    observability.row(k) = row;
    row = row * ss.A;
  }
  // Orthogonal factorisation rather than normal equations: the observability matrix of a slow model is
  // ill conditioned, and squaring its condition number would lose half the digits.
  return observability.completeOrthogonalDecomposition().solve(free);
}

std::complex<double> response(const StateSpace& ss, double frequency, double fs) {
  check_shape(ss, "response");
  const std::complex<double> z = std::polar(1.0, 2.0 * std::numbers::pi * frequency / fs);
  if (ss.order() == 0) return ss.D;
  // H(z) = C·(zI − A)⁻¹·B + D
  Eigen::MatrixXcd M = -ss.A.cast<std::complex<double>>();
  M.diagonal().array() += z;
  const Eigen::VectorXcd x = M.partialPivLu().solve(ss.B.cast<std::complex<double>>());
  return ss.C.transpose().cast<std::complex<double>>().cwiseProduct(x).sum() + ss.D;
}

}  // namespace panelbass::models

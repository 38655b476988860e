#include "models/control/riccati.h"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "models/io/number_text.h"
#include "models/linear/extended_precision.h"

namespace panelbass::models {
namespace {

// The Riccati arithmetic runs in long double, as the realisation does (state_space.cpp): badly damped
// poles near the unit circle make the doubling iteration and the Stein equations ill conditioned, and
// the 11 extra mantissa bits leave the double-precision result accurate to its last digits.
using namespace extended;
using extended::spectral_radius;

// The doubling iteration stops when H changes by less than this fraction of itself (a few long-double
// rounding units), or after kMaxDoublings steps: 2^60 samples is far beyond any decay a double can see.
constexpr Real kDoublingTolerance = 1e-17L;
constexpr int kMaxDoublings = 60;
// Newton (Hewer) steps at most: near the solution each one squares the error; from L = 0 (when the
// doubling fails) the first steps only halve it.
constexpr int kMaxNewtonSteps = 200;
// Newton's residual falls monotonically only near the solution; above this relative residual a step
// that raises it is still taken.
constexpr Real kNewtonNear = 1e-6L;
// solve_dare() refuses a result whose relative residual is above this: the equation was too ill
// conditioned to solve in long double, and the gain would not be the optimum it claims to be.
constexpr double kMaxRelativeResidual = 1e-7;
// A mode is unreachable (PBH test) when [A − λI, B] loses rank to within this fraction of its size.
constexpr Real kReachTolerance = 1e-12L;
// The solution X of the Stein equation X = Fᵀ·X·F + W for a stable F: the discrete Lyapunov
// equation of Fᵀ.
MatrixL solve_stein(const MatrixL& F, const MatrixL& W) { return solve_discrete_lyapunov(F.transpose(), W); }

// [7A] L = (R + BᵀPB)⁻¹·BᵀPA
template <class Matrix, class Vector, class Scalar>
auto gain_of(const Matrix& A, const Vector& B, const Matrix& P, Scalar R) {
  const Vector PB = P * B;
  const Scalar denominator = R + B.dot(PB);
  return ((PB.transpose() * A) / denominator).eval();
}

// The DARE residual AᵀPA − AᵀPB·(R + BᵀPB)⁻¹·BᵀPA + Q − P.
template <class Matrix, class Vector, class Scalar>
Matrix riccati_residual(const Matrix& A, const Vector& B, const Matrix& Q, Scalar R, const Matrix& P) {
  const auto L = gain_of(A, B, P, R);
  const Vector PB = P * B;
  const Matrix APA = A.transpose() * P * A;
  const auto BPA = PB.transpose() * A;
  return APA - BPA.transpose() * L + Q - P;
}

template <class Matrix>
Real relative_residual(const Matrix& residual, const Matrix& P, const Matrix& Q) {
  const Real scale = std::max<Real>({static_cast<Real>(P.norm()), static_cast<Real>(Q.norm()),
                                     std::numeric_limits<Real>::min()});
  return static_cast<Real>(residual.norm()) / scale;
}

// Structured doubling (Chu, Fan, Lin & Wang 2004) on P = Aᵀ·P·(I + G·P)⁻¹·A + Q, G = B·R⁻¹·Bᵀ.
// H_k is the Riccati solution of the 2^k-step horizon and converges quadratically to P, at a rate set
// by the closed loop's slowest pole: a pole at radius 1 − ε needs only about log2(1/ε) steps. Returns
// the last H (non-finite if the iteration broke down); *converged tells whether it settled.
MatrixL doubling(const MatrixL& A, const VectorL& B, const MatrixL& Q, Real R, bool* converged) {
  const Eigen::Index n = A.rows();
  MatrixL Ak = A;
  MatrixL Gk = B * B.transpose() / R;
  MatrixL Hk = Q;
  const MatrixL I = MatrixL::Identity(n, n);
  *converged = false;
  //   W = I + G_k·H_k
  //   A_{k+1} = A_k·W⁻¹·A_k,  G_{k+1} = G_k + A_k·W⁻¹·G_k·A_kᵀ,  H_{k+1} = H_k + A_kᵀ·H_k·W⁻¹·A_k
  for (int step = 0; step < kMaxDoublings && !*converged; ++step) {
    const Eigen::PartialPivLU<MatrixL> W(I + Gk * Hk);
    const MatrixL V1 = W.solve(Ak);
    const MatrixL V2 = W.solve(Gk);
    MatrixL G_next = Gk + Ak * V2 * Ak.transpose();
    MatrixL H_next = Hk + Ak.transpose() * Hk * V1;
    Ak = (Ak * V1).eval();
    G_next = (G_next + G_next.transpose()) / 2.0L;
    H_next = (H_next + H_next.transpose()) / 2.0L;
    if (!H_next.allFinite() || !G_next.allFinite() || !Ak.allFinite()) {
      return MatrixL::Constant(n, n, std::numeric_limits<Real>::quiet_NaN());
    }
    const Real change = (H_next - Hk).norm();
    *converged = change <= kDoublingTolerance * std::max<Real>(H_next.norm(), std::numeric_limits<Real>::min());
    Gk.swap(G_next);
    Hk.swap(H_next);
  }
  return Hk;
}

// Newton's method on the DARE (Hewer 1971) from a P whose gain stabilises A − B·L: with L from P,
// solve the Stein equation P' = (A − BL)ᵀ·P'·(A − BL) + Q + Lᵀ·R·L, at most `steps` times: every step
// while the residual is large, then only steps that lower it. Each step keeps A − BL stable and, once
// close, squares the error.
MatrixL newton(const MatrixL& A, const VectorL& B, const MatrixL& Q, Real R, MatrixL P, int steps) {
  Real best = relative_residual(riccati_residual(A, B, Q, R, P), P, Q);
  for (int step = 0; step < steps; ++step) {
    const RowVectorL L = gain_of(A, B, P, R);
    const MatrixL F = A - B * L;
    if (!(spectral_radius(F) < 1.0L)) break;
    const MatrixL next = solve_stein(F, Q + R * L.transpose() * L);
    if (!next.allFinite()) break;
    const Real residual = relative_residual(riccati_residual(A, B, Q, R, next), next, Q);
    const Real change = (next - P).norm() / std::max<Real>(next.norm(), std::numeric_limits<Real>::min());
    // Far from the solution the residual need not fall at every step; near it, it must.
    if (residual < best || best > kNewtonNear) {
      P = next;
      best = std::min(best, residual);
    } else {
      break;
    }
    if (change <= kDoublingTolerance) break;
  }
  return P;
}

// The PBH test: a mode λ of A with |λ| ≥ 1 that B cannot reach (rank [A − λI, B] < n) leaves the
// Riccati equation without a stabilising solution. Throws naming the mode.
void require_stabilisable(const MatrixL& A, const VectorL& B) {
  const Eigen::Index n = A.rows();
  const Eigen::ComplexEigenSolver<MatrixL> eig(A, false);
  const Real size = std::max<Real>(A.norm() + B.norm(), 1.0L);
  for (Eigen::Index i = 0; i < n; ++i) {
    const ComplexL lambda = eig.eigenvalues()[i];
    if (std::abs(lambda) < 1.0L) continue;
    MatrixCL M(n, n + 1);
    M.leftCols(n) = A.cast<ComplexL>();
    M.leftCols(n).diagonal().array() -= lambda;
    M.col(n) = B.cast<ComplexL>();
    const Eigen::JacobiSVD<MatrixCL> svd(M);
    if (svd.singularValues()[n - 1] <= kReachTolerance * size) {
      throw std::invalid_argument("solve_dare: the pair (A, B) is not stabilisable: the mode at z = " +
                                  number_text(std::complex<double>(lambda)) + " (|z| = " +
                                  number_text(static_cast<double>(std::abs(lambda))) + ") is not reachable from B");
    }
  }
}

void require_finite(const Eigen::MatrixXd& M, const std::string& what) {
  if (!M.allFinite()) throw std::invalid_argument(what + " has a non-finite entry");
}

}  // namespace

Eigen::MatrixXd solve_dare(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, const Eigen::MatrixXd& Q, double R) {
  const Eigen::Index n = A.rows();
  if (A.cols() != n || B.size() != n || Q.rows() != n || Q.cols() != n) {
    throw std::invalid_argument("solve_dare: A must be n×n, B of length n and Q n×n (A " + std::to_string(A.rows()) +
                                "×" + std::to_string(A.cols()) + ", B " + std::to_string(B.size()) + ", Q " +
                                std::to_string(Q.rows()) + "×" + std::to_string(Q.cols()) + ")");
  }
  require_finite(A, "solve_dare: A");
  require_finite(B, "solve_dare: B");
  require_finite(Q, "solve_dare: Q");
  if (!std::isfinite(R) || !(R > 0.0)) throw std::invalid_argument("solve_dare: R must be > 0, got " + number_text(R));
  if (n == 0) return Eigen::MatrixXd(0, 0);
  const double q_size = std::max(Q.norm(), std::numeric_limits<double>::min());
  if ((Q - Q.transpose()).norm() > 1e-12 * q_size) throw std::invalid_argument("solve_dare: Q is not symmetric");
  const double q_min = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Q, Eigen::EigenvaluesOnly).eigenvalues().minCoeff();
  if (q_min < -1e-12 * q_size) {
    throw std::invalid_argument("solve_dare: Q is not positive semidefinite (eigenvalue " + number_text(q_min) + ")");
  }

  const MatrixL Al = A.cast<Real>();
  const VectorL Bl = B.cast<Real>();
  const MatrixL Ql = ((Q + Q.transpose()) / 2.0).cast<Real>();
  const Real Rl = R;
  require_stabilisable(Al, Bl);

  // The doubling iteration first (fast, and it needs no stabilising gain to start from); if it fails
  // on a stiff problem (cheap control with zeros near the unit circle) and A is stable, Newton's
  // iteration from L = 0, which converges monotonically from any stabilising gain.
  bool converged = false;
  MatrixL P = doubling(Al, Bl, Ql, Rl, &converged);
  bool stabilising = P.allFinite() && spectral_radius(MatrixL(Al - Bl * gain_of(Al, Bl, P, Rl))) < 1.0L;
  if (!stabilising && spectral_radius(Al) < 1.0L) {
    P = MatrixL::Zero(n, n);  // the gain of P = 0 is L = 0, stabilising for a stable A
    stabilising = true;
  }
  if (!stabilising) {
    throw std::invalid_argument(
        "solve_dare: no stabilising solution (the doubling iteration " +
        std::string(converged ? "converged to a non-stabilising one" : "did not converge") +
        ": a mode on or near the unit circle that Q does not see, or one B can hardly reach)");
  }
  P = newton(Al, Bl, Ql, Rl, P, kMaxNewtonSteps);

  const RowVectorL L = gain_of(Al, Bl, P, Rl);
  const Real radius = spectral_radius(MatrixL(Al - Bl * L));
  if (!(radius < 1.0L)) {
    throw std::invalid_argument("solve_dare: no stabilising solution: A − B·L keeps a pole of radius " +
                                number_text(static_cast<double>(radius)) +
                                " (a mode on the unit circle that Q does not see)");
  }
  Eigen::MatrixXd result = P.cast<double>();
  result = (result + result.transpose()) / 2.0;
  const double residual =
      static_cast<double>(relative_residual(riccati_residual(A, B, Q, R, result), result, Q));
  if (!(residual <= kMaxRelativeResidual)) {
    throw std::invalid_argument("solve_dare: the Riccati equation is too ill conditioned to solve (relative residual " +
                                number_text(residual) + ")");
  }
  return result;
}

Eigen::RowVectorXd lq_gain(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, const Eigen::MatrixXd& P, double R) {
  const Eigen::Index n = A.rows();
  if (A.cols() != n || B.size() != n || P.rows() != n || P.cols() != n) {
    throw std::invalid_argument("lq_gain: A must be n×n, B of length n and P n×n (A " + std::to_string(A.rows()) + "×" +
                                std::to_string(A.cols()) + ", B " + std::to_string(B.size()) + ", P " +
                                std::to_string(P.rows()) + "×" + std::to_string(P.cols()) + ")");
  }
  if (!std::isfinite(R) || !(R > 0.0)) throw std::invalid_argument("lq_gain: R must be > 0, got " + number_text(R));
  // [7A] L = (R + BᵀPB)⁻¹·BᵀPA
  return gain_of(A, B, P, R);
}

}  // namespace panelbass::models

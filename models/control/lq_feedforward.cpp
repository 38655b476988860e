#include "models/control/lq_feedforward.h"

#include "models/linear/extended_precision.h"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

#include "dsp/random.h"
#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/model_header.h"
#include "models/io/number_text.h"

namespace panelbass::models {
namespace {

// The Riccati arithmetic runs in long double, as the realisation does (state_space.cpp): badly damped
// poles near the unit circle make the doubling iteration and the Stein equations ill conditioned, and
// the 11 extra mantissa bits leave the double-precision result accurate to its last digits.
using namespace extended;

constexpr const char* kKind = "lq_feedforward";

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
// max_input(): the impulse response is summed until a block of it adds less than this fraction of the
// sum, each block at least one time constant long (so the rest of the tail is below it as well).
constexpr double kTailFraction = 1e-12;
constexpr Eigen::Index kMaxImpulseSamples = 1000000;
constexpr Eigen::Index kMinBlock = 256;

std::string show(double v) { return number_text(v); }

std::string show(std::complex<double> z) {
  std::ostringstream out;
  out.precision(6);
  out << z.real() << (z.imag() < 0.0 ? " − " : " + ") << std::abs(z.imag()) << "j";
  return out.str();
}

using extended::spectral_radius;

// The spectral radius of a double-precision matrix.
double spectral_radius(const Eigen::MatrixXd& A) {
  if (A.rows() == 0) return 0.0;
  return Eigen::EigenSolver<Eigen::MatrixXd>(A, false).eigenvalues().cwiseAbs().maxCoeff();
}

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
                                  show(std::complex<double>(lambda)) + " (|z| = " +
                                  show(static_cast<double>(std::abs(lambda))) + ") is not reachable from B");
    }
  }
}

void require_finite(const Eigen::MatrixXd& M, const std::string& what) {
  if (!M.allFinite()) throw std::invalid_argument(what + " has a non-finite entry");
}

Eigen::VectorXd read_vector(const nlohmann::json& v, const std::string& path) {
  if (!v.is_array()) throw ConfigError(path + ": expected an array of numbers, got " + std::string(v.type_name()));
  Eigen::VectorXd x(static_cast<Eigen::Index>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::string where = path + "[" + std::to_string(i) + "]";
    if (!v[i].is_number()) throw ConfigError(where + ": expected a number, got " + std::string(v[i].type_name()));
    const double d = v[i].get<double>();
    if (!std::isfinite(d)) throw ConfigError(where + ": not finite");
    x[static_cast<Eigen::Index>(i)] = d;
  }
  return x;
}

Eigen::MatrixXd read_matrix(const nlohmann::json& v, const std::string& path) {
  if (!v.is_array()) throw ConfigError(path + ": expected an array of rows, got " + std::string(v.type_name()));
  const auto n = static_cast<Eigen::Index>(v.size());
  Eigen::MatrixXd M(n, n);
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::string row_path = path + "[" + std::to_string(i) + "]";
    const Eigen::VectorXd row = read_vector(v[i], row_path);
    if (row.size() != n) {
      throw ConfigError(row_path + ": " + std::to_string(row.size()) + " entries, A must be square (" +
                        std::to_string(n) + " rows)");
    }
    M.row(static_cast<Eigen::Index>(i)) = row.transpose();
  }
  return M;
}

nlohmann::json to_array(const Eigen::VectorXd& x) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index i = 0; i < x.size(); ++i) a.push_back(x[i]);
  return a;
}

nlohmann::json matrix_to_json(const Eigen::MatrixXd& M) {
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index i = 0; i < M.rows(); ++i) rows.push_back(to_array(M.row(i).transpose()));
  return rows;
}

// Samples from one time constant of the slowest pole of `ss` and the filter (at least kMinBlock).
Eigen::Index block_length(const StateSpace& ss, const std::vector<dsp::Biquad>& filter) {
  double radius = spectral_radius(ss.A);
  for (const dsp::Biquad& s : filter) {
    Eigen::Matrix2d companion;
    companion << -s.a1, -s.a2, 1.0, 0.0;
    radius = std::max(radius, spectral_radius(Eigen::MatrixXd(companion)));
  }
  if (!(radius < 1.0)) return kMaxImpulseSamples;
  const double time_constant = -1.0 / std::log(std::max(radius, 1e-300));
  return std::clamp<Eigen::Index>(static_cast<Eigen::Index>(std::ceil(time_constant)), kMinBlock, kMaxImpulseSamples);
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
  if (!std::isfinite(R) || !(R > 0.0)) throw std::invalid_argument("solve_dare: R must be > 0, got " + show(R));
  if (n == 0) return Eigen::MatrixXd(0, 0);
  const double q_size = std::max(Q.norm(), std::numeric_limits<double>::min());
  if ((Q - Q.transpose()).norm() > 1e-12 * q_size) throw std::invalid_argument("solve_dare: Q is not symmetric");
  const double q_min = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Q, Eigen::EigenvaluesOnly).eigenvalues().minCoeff();
  if (q_min < -1e-12 * q_size) {
    throw std::invalid_argument("solve_dare: Q is not positive semidefinite (eigenvalue " + show(q_min) + ")");
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
                                show(static_cast<double>(radius)) +
                                " (a mode on the unit circle that Q does not see)");
  }
  Eigen::MatrixXd result = P.cast<double>();
  result = (result + result.transpose()) / 2.0;
  const double residual =
      static_cast<double>(relative_residual(riccati_residual(A, B, Q, R, result), result, Q));
  if (!(residual <= kMaxRelativeResidual)) {
    throw std::invalid_argument("solve_dare: the Riccati equation is too ill conditioned to solve (relative residual " +
                                show(residual) + ")");
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
  if (!std::isfinite(R) || !(R > 0.0)) throw std::invalid_argument("lq_gain: R must be > 0, got " + show(R));
  // [7A] L = (R + BᵀPB)⁻¹·BᵀPA
  return gain_of(A, B, P, R);
}

StateSpace LqFeedforward::controller() const {
  // [7B] x(k+1) = (A − BL)·x(k) + B·u(k),  u*(k) = −L·x(k) + u(k)
  StateSpace ss;
  ss.A = plant.A - plant.B * L;
  ss.B = plant.B;
  ss.C = -L;
  ss.D = 1.0;
  return ss;
}

StateSpace LqFeedforward::desired() const {
  // [7B] x(k+1) = (A − BL)·x(k) + B·u(k),  y_lin(k) = (C − D·L)·x(k) + D·u(k)  (the thesis's D = 0)
  StateSpace ss;
  ss.A = plant.A - plant.B * L;
  ss.B = plant.B;
  ss.C = plant.C - plant.D * L;
  ss.D = plant.D;
  return ss;
}

Eigen::VectorXcd LqFeedforward::poles() const {
  if (plant.order() == 0) return Eigen::VectorXcd(0);
  return Eigen::EigenSolver<Eigen::MatrixXd>(plant.A - plant.B * L, false).eigenvalues();
}

Eigen::VectorXcd LqFeedforward::zeros() const {
  if (plant.order() == 0) return Eigen::VectorXcd(0);
  // The zeros of (Ac, Bc, Cc, Dc) with Dc = 1 are the eigenvalues of Ac − Bc·Dc⁻¹·Cc = A − BL + BL = A.
  const StateSpace c = controller();
  return Eigen::EigenSolver<Eigen::MatrixXd>(c.A - c.B * c.C / c.D, false).eigenvalues();
}

LqFeedforward design_lq(const LinearModel& model, const LqWeights& weights) {
  if (!std::isfinite(weights.R) || !(weights.R > 0.0)) {
    throw std::invalid_argument("design_lq: R must be > 0, got " + show(weights.R));
  }
  if (!std::isfinite(weights.R0) || !(weights.R0 >= 0.0)) {
    throw std::invalid_argument("design_lq: R0 must be >= 0, got " + show(weights.R0));
  }
  if (!std::isfinite(model.fs) || !(model.fs > 0.0)) {
    throw std::invalid_argument("design_lq: model fs must be > 0, got " + show(model.fs));
  }
  if (!model.tf.all_finite()) throw std::invalid_argument("design_lq: model has a non-finite coefficient");
  const Scaling& s = model.scaling;
  if (!(std::isfinite(s.u_scale) && s.u_scale > 0.0 && std::isfinite(s.y_scale) && s.y_scale > 0.0)) {
    throw std::invalid_argument("design_lq: model scaling must have finite positive scales (u_scale " +
                                show(s.u_scale) + ", y_scale " + show(s.y_scale) + ")");
  }
  if (!model.tf.is_stable()) {
    const Eigen::VectorXcd p = model.tf.poles();
    Eigen::Index worst = 0;
    for (Eigen::Index i = 1; i < p.size(); ++i) {
      if (std::abs(p[i]) > std::abs(p[worst])) worst = i;
    }
    throw std::invalid_argument("design_lq: model is unstable (pole of radius " + show(std::abs(p[worst])) + " at " +
                                show(std::abs(std::arg(p[worst])) * model.fs / (2.0 * std::numbers::pi)) + " Hz)");
  }

  // Design in the model's scaled units (the thesis's units): [7A] with Q = Cᵀ·R0·C, which weights
  // y = C·x (exact for the thesis's D = 0; a model without delay adds D·u* to y, unweighted here).
  const StateSpace scaled = realize(model.tf);
  const Eigen::MatrixXd Q = weights.R0 * scaled.C.transpose() * scaled.C;
  const Eigen::MatrixXd P = solve_dare(scaled.A, scaled.B, Q, weights.R);
  const Eigen::RowVectorXd L = lq_gain(scaled.A, scaled.B, P, weights.R);

  // Raw units: u_raw = u_scale·u, y_raw = y_scale·y (offsets left out), so B·u = (B/u_scale)·u_raw and
  // u*_raw = u_scale·(−L·x + u) = −(L·u_scale)·x + u_raw, which leaves A − B_raw·L_raw = A − B·L.
  LqFeedforward ff;
  ff.plant.A = scaled.A;
  ff.plant.B = scaled.B / s.u_scale;
  ff.plant.C = scaled.C * s.y_scale;
  ff.plant.D = scaled.D * s.y_scale / s.u_scale;
  ff.L = L * s.u_scale;
  ff.weights = weights;
  ff.fs = model.fs;
  ff.meta = {{"model_method", model.method}, {"order", scaled.order()}};
  return ff;
}

InputLimits max_input(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass, Eigen::Index samples,
                      std::uint64_t seed) {
  if (samples < 1) throw std::invalid_argument("max_input: samples must be >= 1, got " + std::to_string(samples));
  const StateSpace c = ff.controller();
  const Eigen::Index n = c.order();
  if (n > 0 && !(spectral_radius(c.A) < 1.0)) {
    throw std::invalid_argument("max_input: the controller is unstable (A − B·L has a pole of radius " +
                                show(spectral_radius(c.A)) + ")");
  }
  for (std::size_t i = 0; i < band_pass.size(); ++i) {
    const dsp::Biquad& b = band_pass[i];
    // A biquad is stable when |a2| < 1 and |a1| < 1 + a2 (the stability triangle).
    if (!(std::abs(b.a2) < 1.0 && std::abs(b.a1) < 1.0 + b.a2)) {
      throw std::invalid_argument("max_input: band-pass section " + std::to_string(i) + " is unstable");
    }
  }

  // One sample of program → band-pass → controller → u*, from the state carried in `filter` and `x`.
  dsp::SosFilter filter(band_pass);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n), next(n);
  const auto step = [&](double in) {
    const double v = filter.process(in);
    // [7B] u*(k) = −L·x(k) + u(k),  x(k+1) = (A − BL)·x(k) + B·u(k)
    const double out = c.C.dot(x) + c.D * v;
    next.noalias() = c.A * x;
    next += c.B * v;
    x.swap(next);
    return out;
  };

  // Worst case: max|u*| ≤ ‖h‖₁·max|in|, with equality for in(k) = sign h(K − k); so 1/‖h‖₁.
  const Eigen::Index block = block_length(c, band_pass);
  double sum = 0.0;
  for (Eigen::Index k = 0; k < kMaxImpulseSamples;) {
    double block_sum = 0.0;
    for (Eigen::Index j = 0; j < block && k < kMaxImpulseSamples; ++j, ++k) block_sum += std::abs(step(k == 0 ? 1.0 : 0.0));
    sum += block_sum;
    if (block_sum <= kTailFraction * sum) break;
  }
  InputLimits limits;
  limits.worst = sum > 0.0 ? 1.0 / sum : std::numeric_limits<double>::infinity();

  // Band-limited white noise: uniform in [−1, 1], through the same chain from rest.
  filter.reset();
  x.setZero();
  dsp::Rng rng(seed);
  double peak = 0.0;
  for (Eigen::Index k = 0; k < samples; ++k) peak = std::max(peak, std::abs(step(rng.uniform(-1.0, 1.0))));
  limits.noise = peak > 0.0 ? 1.0 / peak : std::numeric_limits<double>::infinity();
  return limits;
}

namespace {
// drive_peak's and unity_gain_hz's grid: 2000 frequencies, logarithmic from 1 Hz to just below Nyquist.
Eigen::VectorXd response_grid(double fs) {
  return Eigen::VectorXd::LinSpaced(2000, std::log(1.0), std::log(0.999 * fs / 2.0)).array().exp();
}
}  // namespace

DrivePeak drive_peak(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass) {
  const dsp::SosFilter filter(band_pass);
  const StateSpace controller = ff.controller();
  const Eigen::VectorXd f = response_grid(ff.fs);
  DrivePeak peak{f[0], -std::numeric_limits<double>::infinity()};
  for (Eigen::Index k = 0; k < f.size(); ++k) {
    const double db = 20.0 * std::log10(std::abs(filter.response(f[k], ff.fs) * response(controller, f[k], ff.fs)));
    if (db > peak.gain_db) peak = {f[k], db};
  }
  return peak;
}

std::vector<double> unity_gain_hz(const LqFeedforward& ff) {
  const StateSpace controller = ff.controller();
  const auto boosts = [&](double f) { return std::abs(response(controller, f, ff.fs)) > 1.0; };
  const Eigen::VectorXd f = response_grid(ff.fs);
  std::vector<double> crossings;
  bool previous = boosts(f[0]);
  for (Eigen::Index k = 1; k < f.size(); ++k) {
    const bool current = boosts(f[k]);
    if (current != previous) {
      double lo = f[k - 1], hi = f[k];  // the gain is above 1 at one end only
      while (hi - lo > 1e-9 * hi) {
        const double mid = std::sqrt(lo * hi);
        (boosts(mid) == current ? hi : lo) = mid;
      }
      crossings.push_back(std::sqrt(lo * hi));
    }
    previous = current;
  }
  return crossings;
}

nlohmann::json lq_feedforward_to_json(const LqFeedforward& ff) {
  return {
      {"format", kModelFormat},
      {"kind", kKind},
      {"fs", ff.fs},
      {"params",
       {{"A", matrix_to_json(ff.plant.A)},
        {"B", to_array(ff.plant.B)},
        {"C", to_array(ff.plant.C.transpose())},
        {"D", ff.plant.D},
        {"L", to_array(ff.L.transpose())},
        {"R", ff.weights.R},
        {"R0", ff.weights.R0}}},
      {"meta", ff.meta.is_null() ? nlohmann::json::object() : ff.meta},
  };
}

LqFeedforward lq_feedforward_from_json(const nlohmann::json& j) {
  LqFeedforward ff;
  JsonFields top(j, "model");
  ff.fs = read_model_header(top, kKind);

  const nlohmann::json* params = top.member("params");
  if (params == nullptr) throw ConfigError("model.params: missing");
  JsonFields p(*params, "model.params");
  const auto required = [&p](const char* key) -> const nlohmann::json& {
    const nlohmann::json* v = p.member(key);
    if (v == nullptr) throw ConfigError(p.path_of(key) + ": missing");
    return *v;
  };
  ff.plant.A = read_matrix(required("A"), "model.params.A");
  const Eigen::Index n = ff.plant.A.rows();
  const auto states = [n](const Eigen::Index size, const char* key) {
    if (size != n) {
      throw ConfigError(std::string("model.params.") + key + ": " + std::to_string(size) + " entries, A has " +
                        std::to_string(n) + " states");
    }
  };
  ff.plant.B = read_vector(required("B"), "model.params.B");
  states(ff.plant.B.size(), "B");
  ff.plant.C = read_vector(required("C"), "model.params.C").transpose();
  states(ff.plant.C.size(), "C");
  ff.plant.D = p.number("D");
  ff.L = read_vector(required("L"), "model.params.L").transpose();
  states(ff.L.size(), "L");
  ff.weights.R = p.number("R");
  require_positive(ff.weights.R, "model.params.R");
  ff.weights.R0 = p.number("R0");
  require_non_negative(ff.weights.R0, "model.params.R0");
  p.finish();

  ff.meta = read_model_meta(top);
  top.finish();

  if (n > 0) {
    const Eigen::VectorXcd poles = ff.poles();
    Eigen::Index worst = 0;
    for (Eigen::Index i = 1; i < poles.size(); ++i) {
      if (std::abs(poles[i]) > std::abs(poles[worst])) worst = i;
    }
    if (!(std::abs(poles[worst]) < 1.0)) {
      throw ConfigError("model.params.L: A − B·L is unstable, pole of radius " + show(std::abs(poles[worst])) + " at " +
                        show(std::abs(std::arg(poles[worst])) * ff.fs / (2.0 * std::numbers::pi)) + " Hz");
    }
  }
  return ff;
}

}  // namespace panelbass::models

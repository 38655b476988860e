// The LQ feedforward controller of ch. 7, each property checked against a computation written out
// here: the Riccati equation's residual, the scalar quadratic solved by hand, the cost summed along a
// simulated trajectory and a finite-horizon backward recursion, the loop of fig. 7.1 run sample by
// sample, the model's poles, and the ℓ1 norm of a directly computed impulse response.
#include "models/control/lq_feedforward.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "dsp/butterworth.h"
#include "dsp/frequency_grid.h"
#include "dsp/random.h"
#include "models/io/config_error.h"
#include "tests/support/expect_error.h"
#include "tests/support/linear_systems.h"
#include "tests/support/vectors.h"

namespace panelbass::models {
namespace {

using testing_support::expect_invalid;
using testing_support::one_line_error;
using testing_support::vec;

// The DARE written out: AᵀPA − AᵀPB·(R + BᵀPB)⁻¹·BᵀPA + Q − P, relative to ‖P‖.
double relative_residual(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, const Eigen::MatrixXd& Q, double R,
                         const Eigen::MatrixXd& P) {
  const Eigen::VectorXd PB = P * B;
  const Eigen::VectorXd ATPB = A.transpose() * PB;
  const Eigen::MatrixXd res = A.transpose() * P * A - ATPB * ATPB.transpose() / (R + B.dot(PB)) + Q - P;
  return res.norm() / P.norm();
}

double spectral_radius(const Eigen::MatrixXd& A) {
  return Eigen::EigenSolver<Eigen::MatrixXd>(A, false).eigenvalues().cwiseAbs().maxCoeff();
}

// A transducer-like model: three resonances (one badly damped), a two-sample delay, a zero outside
// the unit circle; scaled units differ from raw ones so that the folding of the scaling is exercised.
LinearModel transducer_model(int nk = 2) {
  LinearModel m;
  Eigen::VectorXcd poles(6);
  poles << std::polar(0.995, 0.08), std::polar(0.995, -0.08), std::polar(0.95, 0.6), std::polar(0.95, -0.6),
      std::polar(0.85, 1.7), std::polar(0.85, -1.7);
  m.tf.a = testing_support::denominator(poles);
  m.tf.b = vec({0.02, 0.05, -0.03, 0.01, 0.015});
  m.tf.nk = nk;
  m.fs = 3000.0;
  m.scaling = Scaling{0.1, 0.5, -0.2, 3.0};
  m.method = "oe";
  return m;
}

// `count` conjugate pole pairs at radius in [r_min, r_max], in modal 2×2 blocks, mixed by a random
// orthogonal matrix: a well-conditioned realisation of badly damped modes.
StateSpace badly_damped(int pairs, double r_min, double r_max, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int n = 2 * pairs;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < pairs; ++i) {
    const double r = r_min + (r_max - r_min) * unit(rng);
    const double th = std::numbers::pi * (0.01 + 0.9 * unit(rng));
    A.block(2 * i, 2 * i, 2, 2) << r * std::cos(th), -r * std::sin(th), r * std::sin(th), r * std::cos(th);
  }
  Eigen::MatrixXd M(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) M(i, j) = unit(rng) - 0.5;
  const Eigen::MatrixXd U = Eigen::HouseholderQR<Eigen::MatrixXd>(M).householderQ();
  StateSpace ss;
  ss.A = U * A * U.transpose();
  ss.B = Eigen::VectorXd::NullaryExpr(n, [&] { return unit(rng) - 0.5; });
  ss.C = Eigen::RowVectorXd::NullaryExpr(n, [&] { return unit(rng) - 0.5; });
  return ss;
}

// V_c = Σ_{k=0}^{N−1} xᵀQx + u·R·u along x(k+1) = A·x + B·u, u = −L·x, from x0 (no program input).
double cost_by_simulation(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, const Eigen::MatrixXd& Q, double R,
                          const Eigen::RowVectorXd& L, Eigen::VectorXd x, int steps) {
  double v = 0.0;
  for (int k = 0; k < steps; ++k) {
    const double u = -L.dot(x);
    v += x.dot(Q * x) + R * u * u;
    x = (A * x + B * u).eval();
  }
  return v;
}

TEST(SolveDare, ScalarCaseMatchesTheQuadraticSolvedByHand) {
  // p = a²p − a²b²p²/(r + b²p) + q, multiplied by (r + b²p):
  //   b²·p² + (r(1 − a²) − q·b²)·p − q·r = 0,  the positive root is the stabilising one.
  for (const double a : {0.9, -0.5, 1.5}) {
    const double b = 0.7, q = 2.0, r = 0.3;
    const double beta = r * (1.0 - a * a) - q * b * b;
    const double p = (-beta + std::sqrt(beta * beta + 4.0 * b * b * q * r)) / (2.0 * b * b);
    const Eigen::MatrixXd P = solve_dare(Eigen::MatrixXd::Constant(1, 1, a), vec({b}), Eigen::MatrixXd::Constant(1, 1, q), r);
    EXPECT_NEAR(P(0, 0), p, 1e-13 * p) << "a = " << a;
    const Eigen::RowVectorXd L = lq_gain(Eigen::MatrixXd::Constant(1, 1, a), vec({b}), P, r);
    EXPECT_NEAR(L[0], a * b * p / (r + b * b * p), 1e-13) << "a = " << a;
    EXPECT_LT(std::abs(a - b * L[0]), 1.0) << "a = " << a;
  }
}

TEST(SolveDare, SatisfiesItsEquationOnTheTransducerModel) {
  const StateSpace ss = realize(transducer_model().tf);
  for (const double R : {3.0, 1.0, 1e-5}) {
    const Eigen::MatrixXd Q = 20.0 * ss.C.transpose() * ss.C;
    const Eigen::MatrixXd P = solve_dare(ss.A, ss.B, Q, R);
    EXPECT_LT(relative_residual(ss.A, ss.B, Q, R, P), 1e-9) << "R = " << R;
    EXPECT_LT((P - P.transpose()).norm(), 1e-14 * P.norm());
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P).eigenvalues().minCoeff(), -1e-12 * P.norm());
    EXPECT_LT(spectral_radius(ss.A - ss.B * lq_gain(ss.A, ss.B, P, R)), 1.0);
  }
}

TEST(SolveDare, SatisfiesItsEquationAtOrder30WithPolesNearTheUnitCircle) {
  const StateSpace ss = badly_damped(15, 0.999, 0.99995, 7);
  for (const double R : {3.0, 1e-5}) {
    const Eigen::MatrixXd Q = 20.0 * ss.C.transpose() * ss.C;
    const Eigen::MatrixXd P = solve_dare(ss.A, ss.B, Q, R);
    EXPECT_LT(relative_residual(ss.A, ss.B, Q, R, P), 1e-9) << "R = " << R;
    EXPECT_LT(spectral_radius(ss.A - ss.B * lq_gain(ss.A, ss.B, P, R)), 1.0) << "R = " << R;
  }
}

TEST(SolveDare, SatisfiesItsEquationForA30thOrderPolynomialModel) {
  // Through realize(), as design_lq() uses it: 15 resonances up to radius 0.9995.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::VectorXcd poles(30);
  for (int i = 0; i < 30; i += 2) {
    poles[i] = std::polar(0.95 + 0.0495 * unit(rng), std::numbers::pi * (0.02 + 0.9 * unit(rng)));
    poles[i + 1] = std::conj(poles[i]);
  }
  TransferFunction tf;
  tf.a = testing_support::denominator(poles);
  tf.b = Eigen::VectorXd::NullaryExpr(30, [&] { return unit(rng) - 0.5; });
  tf.nk = 1;
  const StateSpace ss = realize(tf);
  ASSERT_EQ(ss.order(), 30);
  for (const double R : {3.0, 1e-5}) {
    const Eigen::MatrixXd Q = 20.0 * ss.C.transpose() * ss.C;
    const Eigen::MatrixXd P = solve_dare(ss.A, ss.B, Q, R);
    EXPECT_LT(relative_residual(ss.A, ss.B, Q, R, P), 1e-9) << "R = " << R;
  }
}

TEST(SolveDare, StabilisesAnUnstablePairAndAgreesWithTheBackwardRecursion) {
  // An unstable but reachable A, Q = I: the backward recursion
  //   P_{k} = Q + AᵀP_{k+1}A − AᵀP_{k+1}B(R + BᵀP_{k+1}B)⁻¹BᵀP_{k+1}A from P_N = 0
  // (the finite-horizon LQ problem) converges to the stabilising solution as the horizon grows.
  Eigen::MatrixXd A(3, 3);
  A << 1.1, 0.4, 0.0, -0.3, 0.8, 0.2, 0.1, 0.0, 0.5;
  const Eigen::VectorXd B = vec({0.0, 1.0, 0.5});
  const Eigen::MatrixXd Q = Eigen::MatrixXd::Identity(3, 3);
  const double R = 0.7;
  const Eigen::MatrixXd P = solve_dare(A, B, Q, R);
  Eigen::MatrixXd Pk = Eigen::MatrixXd::Zero(3, 3);
  for (int k = 0; k < 2000; ++k) {
    const Eigen::VectorXd ATPB = A.transpose() * Pk * B;
    Pk = (Q + A.transpose() * Pk * A - ATPB * ATPB.transpose() / (R + B.dot(Pk * B))).eval();
  }
  EXPECT_LT((P - Pk).norm(), 1e-10 * P.norm());
  EXPECT_LT(spectral_radius(A - B * lq_gain(A, B, P, R)), 1.0);
}

TEST(SolveDare, GainMinimisesTheCostAlongSimulatedTrajectories) {
  const StateSpace ss = realize(transducer_model().tf);
  const Eigen::MatrixXd Q = 20.0 * ss.C.transpose() * ss.C;
  const double R = 3.0;
  const Eigen::MatrixXd P = solve_dare(ss.A, ss.B, Q, R);
  const Eigen::RowVectorXd L = lq_gain(ss.A, ss.B, P, R);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  const int steps = 20000;  // the slowest closed-loop pole (< 0.996) has decayed by e^-80
  for (int trial = 0; trial < 4; ++trial) {
    const Eigen::VectorXd x0 = Eigen::VectorXd::NullaryExpr(ss.order(), [&] { return normal(rng); });
    const double optimum = cost_by_simulation(ss.A, ss.B, Q, R, L, x0, steps);
    // The optimal cost from x0 is x0ᵀ·P·x0.
    EXPECT_NEAR(optimum, x0.dot(P * x0), 1e-9 * optimum);
    for (const double size : {1e-3, 1e-2}) {
      const Eigen::RowVectorXd dL = Eigen::RowVectorXd::NullaryExpr(ss.order(), [&] { return normal(rng); });
      for (const double sign : {1.0, -1.0}) {
        const Eigen::RowVectorXd other = L + sign * size * L.norm() * dL.normalized();
        if (!(spectral_radius(ss.A - ss.B * other) < 1.0)) continue;
        EXPECT_GT(cost_by_simulation(ss.A, ss.B, Q, R, other, x0, steps), optimum)
            << "trial " << trial << ", perturbation " << sign * size;
      }
    }
  }
}

TEST(SolveDare, RefusesBadArgumentsNamingThem) {
  const Eigen::MatrixXd A = Eigen::MatrixXd::Identity(2, 2) * 0.5;
  const Eigen::MatrixXd Q = Eigen::MatrixXd::Identity(2, 2);
  expect_invalid([&] { solve_dare(A, vec({1.0}), Q, 1.0); }, "B 1");
  expect_invalid([&] { solve_dare(A, vec({1.0, 0.0}), Q, 0.0); }, "R must be > 0");
  expect_invalid([&] { solve_dare(A, vec({1.0, 0.0}), Q, -2.0); }, "R must be > 0");
  Eigen::MatrixXd skew = Q;
  skew(0, 1) = 0.3;
  expect_invalid([&] { solve_dare(A, vec({1.0, 0.0}), skew, 1.0); }, "Q is not symmetric");
  expect_invalid([&] { solve_dare(A, vec({1.0, 0.0}), -Q, 1.0); }, "Q is not positive semidefinite");
  Eigen::MatrixXd bad = A;
  bad(1, 1) = std::numeric_limits<double>::quiet_NaN();
  expect_invalid([&] { solve_dare(bad, vec({1.0, 0.0}), Q, 1.0); }, "A has a non-finite entry");
  // An unstable mode B cannot reach: no stabilising solution, and the message names the mode.
  Eigen::MatrixXd unreachable(2, 2);
  unreachable << 1.2, 0.0, 0.0, 0.5;
  const std::string message = one_line_error<std::invalid_argument>([&] { solve_dare(unreachable, vec({0.0, 1.0}), Q, 1.0); });
  EXPECT_NE(message.find("not stabilisable"), std::string::npos) << message;
  EXPECT_NE(message.find("1.2"), std::string::npos) << message;
  // A reachable mode on the unit circle that Q does not see: the optimum leaves it there, so there is
  // no stabilising solution either.
  Eigen::MatrixXd marginal(2, 2);
  marginal << 1.0, 0.0, 0.0, 0.5;
  Eigen::MatrixXd sees_second = Eigen::MatrixXd::Zero(2, 2);
  sees_second(1, 1) = 1.0;
  expect_invalid([&] { solve_dare(marginal, vec({1.0, 1.0}), sees_second, 1.0); }, "no stabilising solution");
}

// The loop of fig. 7.1 in the model's scaled units, sample by sample: u*_s = −L_s·x + u_s applied to the
// plant x(k+1) = A·x + B·u*_s, y = C·x + D·u*_s; returned in raw units (u = u_scale·u_s, y = y_scale·y_s).
struct LoopOutput {
  Eigen::VectorXd u_star, y;
};
LoopOutput run_fig_7_1(const LinearModel& m, const StateSpace& ss, const Eigen::RowVectorXd& L_scaled,
                       const Eigen::VectorXd& u_raw) {
  LoopOutput out{Eigen::VectorXd(u_raw.size()), Eigen::VectorXd(u_raw.size())};
  Eigen::VectorXd x = Eigen::VectorXd::Zero(ss.order());
  for (Eigen::Index k = 0; k < u_raw.size(); ++k) {
    const double u = u_raw[k] / m.scaling.u_scale;
    const double u_star = -L_scaled.dot(x) + u;
    const double y = ss.C.dot(x) + ss.D * u_star;
    x = (ss.A * x + ss.B * u_star).eval();
    out.u_star[k] = u_star * m.scaling.u_scale;
    out.y[k] = y * m.scaling.y_scale;
  }
  return out;
}

TEST(LqFeedforward, ControllerAndDesiredResponseEqualTheLoopOfFig71) {
  for (const int nk : {2, 0}) {  // nk = 0: a direct term D ≠ 0, where y_lin = (C − D·L)·x + D·u
    const LinearModel m = transducer_model(nk);
    const LqWeights w{1e-2, 20.0};
    const LqFeedforward ff = design_lq(m, w);
    const StateSpace ss = realize(m.tf);
    const Eigen::RowVectorXd L_scaled =
        lq_gain(ss.A, ss.B, solve_dare(ss.A, ss.B, w.R0 * ss.C.transpose() * ss.C, w.R), w.R);
    EXPECT_LT((ff.L - L_scaled * m.scaling.u_scale).norm(), 1e-12 * ff.L.norm());

    const Eigen::VectorXd u = testing_support::gaussian(3000, 0.3, 5);
    const LoopOutput loop = run_fig_7_1(m, ss, L_scaled, u);
    const Eigen::VectorXd u_star = simulate(ff.controller(), u);
    const Eigen::VectorXd y_lin = simulate(ff.desired(), u);
    EXPECT_LT((u_star - loop.u_star).cwiseAbs().maxCoeff(), 1e-12 * loop.u_star.cwiseAbs().maxCoeff()) << "nk " << nk;
    EXPECT_LT((y_lin - loop.y).cwiseAbs().maxCoeff(), 1e-12 * loop.y.cwiseAbs().maxCoeff()) << "nk " << nk;
    // The plant in raw units, driven by u*, gives y_lin too (the controller in series with the model).
    // (the model removes u_offset from its input and adds y_offset to its output; undo both)
    const Eigen::VectorXd through = m.simulate((u_star.array() + m.scaling.u_offset).matrix()).array() - m.scaling.y_offset;
    EXPECT_LT((through - loop.y).cwiseAbs().maxCoeff(), 1e-9 * loop.y.cwiseAbs().maxCoeff()) << "nk " << nk;
  }
}

TEST(LqFeedforward, ControllerZerosAreTheModelPolesAndResponsesMultiply) {
  const LinearModel m = transducer_model();
  const LqFeedforward ff = design_lq(m, {3.0, 20.0});
  const Eigen::VectorXcd zeros = ff.zeros();
  const Eigen::VectorXcd model_poles = m.tf.poles();
  ASSERT_EQ(zeros.size(), model_poles.size());
  for (Eigen::Index i = 0; i < model_poles.size(); ++i) {
    EXPECT_LT((zeros.array() - model_poles[i]).abs().minCoeff(), 1e-9) << "model pole " << model_poles[i];
  }
  // The poles: eigenvalues of A − BL, all inside the unit circle and moved from the model's.
  const Eigen::VectorXcd poles = ff.poles();
  EXPECT_LT(poles.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_LT(poles.cwiseAbs().maxCoeff(), model_poles.cwiseAbs().maxCoeff());
  // y_lin/u = (y/u*)·(u*/u) at every frequency: the model's response (raw units) times the controller's.
  for (const double f : {10.0, 40.0, 100.0, 380.0, 1000.0, 1400.0}) {
    const std::complex<double> model = m.tf.response(f, m.fs) * m.scaling.y_scale / m.scaling.u_scale;
    const std::complex<double> expected = model * response(ff.controller(), f, m.fs);
    EXPECT_LT(std::abs(response(ff.desired(), f, m.fs) - expected), 1e-9 * std::abs(expected)) << f << " Hz";
  }
}

TEST(LqFeedforward, LargeInputWeightTurnsTheFeedbackOff) {
  // As R → ∞, P → P₀ = Σ_k (Aᵀ)^k·Q·A^k (the cost of leaving the model alone) and R·L → Bᵀ·P₀·A
  // (scaled units): L falls like 1/R towards 0 and the poles return to the model's.
  const LinearModel m = transducer_model();
  const StateSpace ss = realize(m.tf);
  const Eigen::MatrixXd Q = 20.0 * ss.C.transpose() * ss.C;
  Eigen::MatrixXd P0 = Eigen::MatrixXd::Zero(ss.order(), ss.order());
  Eigen::MatrixXd Ak = Eigen::MatrixXd::Identity(ss.order(), ss.order());
  for (int k = 0; k < 40000; ++k) {  // the slowest pole 0.995: 0.995^80000 ≈ e^-400
    P0 += Ak.transpose() * Q * Ak;
    Ak = (Ak * ss.A).eval();
  }
  const Eigen::RowVectorXd limit = ss.B.transpose() * P0 * ss.A;
  double previous_gain = std::numeric_limits<double>::infinity(), previous_shift = previous_gain;
  double previous_distance = 0.0;
  const Eigen::VectorXcd model_poles = m.tf.poles();
  for (const double R : {1e2, 1e4, 1e6, 1e8, 1e10}) {
    const LqFeedforward ff = design_lq(m, {R, 20.0});
    const Eigen::RowVectorXd scaled_gain = ff.L / m.scaling.u_scale;
    EXPECT_LT(ff.L.norm(), previous_gain) << "R = " << R;
    previous_gain = ff.L.norm();
    double shift = 0.0;
    for (Eigen::Index i = 0; i < model_poles.size(); ++i) {
      shift = std::max(shift, (ff.poles().array() - model_poles[i]).abs().minCoeff());
    }
    EXPECT_LT(shift, previous_shift) << "R = " << R;
    previous_shift = shift;
    // R·L = Bᵀ·P·A·R/(R + BᵀPB) with P = P₀ + O(1/R): the distance to the limit falls like 1/R once R
    // is well above BᵀP₀B (about 1e4 here: the slow resonance makes leaving the model alone costly).
    const double distance = (R * scaled_gain - limit).norm() / limit.norm();
    if (R >= 1e8) {
      EXPECT_NEAR(distance / previous_distance, 1e-2, 2e-3) << "R = " << R;
    }
    previous_distance = distance;
  }
  EXPECT_LT(previous_distance, 1e-4);
  EXPECT_LT(previous_shift, 1e-4);
}

TEST(LqFeedforward, DesignRefusesBadWeightsAndUnstableModels) {
  const LinearModel m = transducer_model();
  expect_invalid([&] { design_lq(m, {0.0, 20.0}); }, "R must be > 0");
  expect_invalid([&] { design_lq(m, {-1.0, 20.0}); }, "R must be > 0");
  expect_invalid([&] { design_lq(m, {1.0, -1.0}); }, "R0 must be >= 0");
  expect_invalid([&] { design_lq(m, {std::numeric_limits<double>::quiet_NaN(), 20.0}); }, "R must be > 0");
  LinearModel unstable = m;
  unstable.tf.a = testing_support::denominator(vec({1.05, 0.5}).cast<std::complex<double>>());
  expect_invalid([&] { design_lq(unstable, {1.0, 20.0}); }, "unstable");
}

// h: the impulse response of band-pass · controller, written out with SosFilter and simulate().
Eigen::VectorXd impulse_response(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass, Eigen::Index n) {
  Eigen::VectorXd impulse = Eigen::VectorXd::Zero(n);
  impulse[0] = 1.0;
  dsp::SosFilter filter(band_pass);
  return simulate(ff.controller(), filter.process(impulse));
}

TEST(LqFeedforward, MaxInputIsTheInverseL1NormAndNoiseAllowsMore) {
  const LinearModel m = transducer_model();
  for (const double R : {3.0, 1e-5}) {
    const LqFeedforward ff = design_lq(m, {R, 20.0});
    for (const auto& band : {std::vector<dsp::Biquad>{}, dsp::butterworth_bandpass(2, 20.0, 1200.0, m.fs),
                             dsp::butterworth_lowpass(2, 1200.0, m.fs)}) {
      const InputLimits limits = max_input(ff, band, 20000, 4);
      // A direct sum over 400 000 samples: the slowest pole (radius < 0.9996) has decayed by e^-160.
      const double l1 = impulse_response(ff, band, 400000).cwiseAbs().sum();
      EXPECT_NEAR(limits.worst, 1.0 / l1, 1e-10 / l1) << "R = " << R << ", " << band.size() << " sections";
      EXPECT_GE(limits.noise, limits.worst);
      // The noise case, written out: uniform noise from the same seed through band-pass and controller.
      dsp::Rng rng(4);
      Eigen::VectorXd noise(20000);
      for (Eigen::Index k = 0; k < noise.size(); ++k) noise[k] = rng.uniform(-1.0, 1.0);
      dsp::SosFilter filter(band);
      const double peak = simulate(ff.controller(), filter.process(noise)).cwiseAbs().maxCoeff();
      EXPECT_NEAR(limits.noise, 1.0 / peak, 1e-12 / peak);
    }
  }
}

TEST(LqFeedforward, UnityGainOfAFirstOrderControllerIsWhereItsZeroAndPoleAreEquallyFar) {
  // u*/u = 1 − L(zI − A + BL)⁻¹B is (z − z0)/(z − p0) for one state (its zero the model's pole, its pole
  // the loop's), so |u*/u| = 1 where |e^jω − z0| = |e^jω − p0|: cos ω = (z0 + p0)/2.
  LinearModel m;
  m.tf.a = vec({-0.9});
  m.tf.b = vec({0.1});
  m.tf.nk = 1;
  m.fs = 3000.0;
  m.scaling = Scaling{0.1, 0.5, -0.2, 3.0};
  for (const double R : {1e-2, 1.0}) {
    const LqFeedforward ff = design_lq(m, {R, 20.0});
    const double z0 = ff.zeros()[0].real(), p0 = ff.poles()[0].real();
    ASSERT_LT(p0, z0) << "R = " << R << ": the loop should pull the pole in";
    const double expected = std::acos((z0 + p0) / 2.0) * m.fs / (2.0 * std::numbers::pi);
    const std::vector<double> crossings = unity_gain_hz(ff);
    ASSERT_EQ(crossings.size(), 1u) << "R = " << R;
    EXPECT_NEAR(crossings[0], expected, 1e-8 * expected) << "R = " << R;
  }
}

TEST(LqFeedforward, UnityGainCrossingsAreEveryPlaceTheGainPassesThroughOne) {
  const LinearModel m = transducer_model();
  for (const double R : {3.0, 1e-5}) {
    const LqFeedforward ff = design_lq(m, {R, 20.0});
    const StateSpace controller = ff.controller();
    const auto above_one = [&](double f) { return std::abs(response(controller, f, m.fs)) > 1.0; };
    // Counted on a linear grid of its own, 20 times finer than the search's near Nyquist.
    int sign_changes = 0;
    const int n = 40000;
    for (int k = 1; k < n; ++k) {
      const double f0 = 1.0 + (0.999 * m.fs / 2.0 - 1.0) * (k - 1) / (n - 1);
      const double f1 = 1.0 + (0.999 * m.fs / 2.0 - 1.0) * k / (n - 1);
      sign_changes += above_one(f0) != above_one(f1);
    }
    const std::vector<double> crossings = unity_gain_hz(ff);
    ASSERT_EQ(static_cast<int>(crossings.size()), sign_changes) << "R = " << R;
    ASSERT_GE(sign_changes, 1) << "R = " << R;
    EXPECT_TRUE(std::is_sorted(crossings.begin(), crossings.end()));
    for (const double f : crossings) {
      EXPECT_NEAR(std::abs(response(controller, f, m.fs)), 1.0, 1e-7) << "R = " << R << ", " << f << " Hz";
      EXPECT_NE(above_one(f * (1.0 - 1e-6)), above_one(f * (1.0 + 1e-6))) << "R = " << R << ", " << f << " Hz";
    }
  }
}

TEST(LqFeedforward, JsonRoundTripIsExact) {
  LqFeedforward ff = design_lq(transducer_model(), {3.0, 20.0});
  ff.meta = {{"model", "lin.json"}, {"bandpass", {20.0, 1200.0}}};
  const nlohmann::json j = lq_feedforward_to_json(ff);
  EXPECT_EQ(j["kind"], "lq_feedforward");
  const LqFeedforward back = lq_feedforward_from_json(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(back.plant.A, ff.plant.A);
  EXPECT_EQ(back.plant.B, ff.plant.B);
  EXPECT_EQ(back.plant.C, ff.plant.C);
  EXPECT_EQ(back.plant.D, ff.plant.D);
  EXPECT_EQ(back.L, ff.L);
  EXPECT_EQ(back.weights.R, 3.0);
  EXPECT_EQ(back.weights.R0, 20.0);
  EXPECT_EQ(back.fs, ff.fs);
  EXPECT_EQ(back.meta, ff.meta);
}

TEST(LqFeedforward, JsonValidationNamesTheKey) {
  const nlohmann::json good = lq_feedforward_to_json(design_lq(transducer_model(), {3.0, 20.0}));
  const auto error_of = [](const nlohmann::json& j) {
    return one_line_error<ConfigError>([&] { lq_feedforward_from_json(j); });
  };
  const auto expect_names = [&](const nlohmann::json& j, const std::string& part) {
    const std::string message = error_of(j);
    EXPECT_NE(message.find(part), std::string::npos) << "expected \"" << part << "\" in: " << message;
  };
  nlohmann::json j = good;
  j["kind"] = "linear";
  expect_names(j, "model.kind: expected \"lq_feedforward\", got \"linear\"");
  j = good;
  j["format"] = "other/2";
  expect_names(j, "model.format");
  j = good;
  j["fs"] = 0.0;
  expect_names(j, "model.fs");
  j = good;
  j["params"]["L"].erase(0);
  expect_names(j, "model.params.L: 5 entries, A has 6 states");
  j = good;
  j["params"]["B"].push_back(1.0);
  expect_names(j, "model.params.B: 7 entries, A has 6 states");
  j = good;
  j["params"]["C"] = nlohmann::json::array();
  expect_names(j, "model.params.C: 0 entries");
  j = good;
  j["params"]["A"][2].erase(0);
  expect_names(j, "model.params.A[2]: 5 entries");
  j = good;
  j["params"]["A"][1][3] = std::numeric_limits<double>::quiet_NaN();
  expect_names(j, "model.params.A[1][3]: not finite");
  j = good;
  j["params"]["L"][4] = std::numeric_limits<double>::infinity();
  expect_names(j, "model.params.L[4]: not finite");
  j = good;
  j["params"]["B"][0] = "x";
  expect_names(j, "model.params.B[0]: expected a number");
  j = good;
  j["params"]["D"] = std::numeric_limits<double>::quiet_NaN();
  expect_names(j, "model.params.D");
  j = good;
  j["params"].erase("L");
  expect_names(j, "model.params.L: missing");
  j = good;
  j["params"]["R"] = 0.0;
  expect_names(j, "model.params.R: must be > 0");
  j = good;
  j["params"]["R0"] = -1.0;
  expect_names(j, "model.params.R0: must be >= 0");
  j = good;
  j["params"]["gain"] = 2.0;
  expect_names(j, "model.params.gain");
  // A − BL unstable: a feedback that pushes the slow resonance outside the unit circle.
  j = good;
  const LqFeedforward ff = lq_feedforward_from_json(good);
  Eigen::RowVectorXd L = -ff.L * 50.0;
  for (Eigen::Index i = 0; i < L.size(); ++i) j["params"]["L"][static_cast<std::size_t>(i)] = L[i];
  ASSERT_GE(spectral_radius(ff.plant.A - ff.plant.B * L), 1.0);
  expect_names(j, "model.params.L: A − B·L is unstable");
}

// An acceleration-like minimum-phase model: the three resonances of transducer_model(), a double zero
// near z = 1 (the response falls 12 dB/octave towards DC) and one at −0.5, a one-sample delay.
LinearModel acceleration_model() {
  LinearModel m = transducer_model(1);
  Eigen::VectorXcd zeros(3);
  zeros << 0.995, 0.995, -0.5;
  Eigen::VectorXd b(4);
  b[0] = 1.0;
  b.tail(3) = testing_support::denominator(zeros);
  m.tf.b = 0.01 * b;
  return m;
}

// |y/u| of the controlled model, computed as the raw model's transfer function times the controller's.
double controlled_gain(const LinearModel& m, const LqFeedforward& ff, double f) {
  const std::complex<double> model = m.tf.response(f, m.fs) * m.scaling.y_scale / m.scaling.u_scale;
  return std::abs(model * response(ff.controller(), f, m.fs));
}

// `n` samples uniform in [−1, 1] from dsp::Rng(seed): the noise max_input() and noise_excursion() use.
Eigen::VectorXd target_test_noise(Eigen::Index n, std::uint64_t seed) {
  dsp::Rng rng(seed);
  Eigen::VectorXd u(n);
  for (Eigen::Index k = 0; k < n; ++k) u[k] = rng.uniform(-1.0, 1.0);
  return u;
}

TEST(LqTarget, CheapControlFollowsTheTargetBand) {
  // R → 0: y/u = the model's gain at mid band × the Butterworth high-pass (its own biquads), within 0.5 dB
  // from the corner to 1200 Hz; the design without a target instead lifts 10 Hz (relative to 300 Hz) far
  // above the band's shape.
  const LinearModel m = acceleration_model();
  const LqTargetBand band{40.0, 2, 300.0};
  const LqFeedforward ff = design_lq(m, {1e-7, 20.0}, band);
  ASSERT_TRUE(ff.has_target());
  EXPECT_EQ(ff.target.delay, 1);
  const dsp::SosFilter hp(dsp::butterworth_highpass(2, 40.0, m.fs));
  const double model_mid = std::abs(m.tf.response(300.0, m.fs)) * m.scaling.y_scale / m.scaling.u_scale;
  const auto target = [&](double f) { return model_mid * std::abs(hp.response(f, m.fs)) / std::abs(hp.response(300.0, m.fs)); };
  EXPECT_NEAR(std::abs(ff.target.gain), model_mid / std::abs(hp.response(300.0, m.fs)), 1e-9 * model_mid);
  double worst_db = 0.0;
  for (const double f : dsp::log_spaced(40.0, 1200.0, 200)) {
    worst_db = std::max(worst_db, std::abs(20.0 * std::log10(controlled_gain(m, ff, f) / target(f))));
    EXPECT_NEAR(std::abs(response(ff.desired(), f, m.fs)), controlled_gain(m, ff, f), 1e-9 * target(f));
  }
  EXPECT_LT(worst_db, 0.5);
  const LqFeedforward flat = design_lq(m, {1e-7, 20.0});
  const double flat_lift_db = 20.0 * std::log10(controlled_gain(m, flat, 10.0) / controlled_gain(m, flat, 300.0) /
                                                (target(10.0) / target(300.0)));
  EXPECT_GT(flat_lift_db, 20.0);
  EXPECT_LT(controlled_gain(m, ff, 10.0), 1.5 * target(10.0));
}

TEST(LqTarget, HigherCornerAsksLessDriveAtLowFrequencies) {
  const LinearModel m = acceleration_model();
  double previous = std::abs(response(design_lq(m, {1e-4, 20.0}).controller(), 10.0, m.fs));
  for (const double hz : {20.0, 40.0, 80.0, 160.0}) {
    const LqFeedforward ff = design_lq(m, {1e-4, 20.0}, {hz, 2, 400.0});
    const double gain = std::abs(response(ff.controller(), 10.0, m.fs));
    EXPECT_LT(gain, previous) << hz << " Hz";
    previous = gain;
  }
}

TEST(LqTarget, ControllerIsTheLoopOnTheAugmentedState) {
  // u*(k) = −L·x(k) − L_r·x_r(k) + l·u(k), x(k+1) = A·x(k) + B·u*(k), x_r(k+1) = A_r·x_r(k) + B_r·u(k),
  // run sample by sample against controller() and desired() simulated as state spaces.
  const LinearModel m = acceleration_model();
  const LqFeedforward ff = design_lq(m, {1e-3, 20.0}, {40.0, 3, 300.0});
  const Eigen::VectorXd u = target_test_noise(400, 3);
  const Eigen::VectorXd drive = simulate(ff.controller(), u), y_lin = simulate(ff.desired(), u);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(ff.plant.order()), xr = Eigen::VectorXd::Zero(ff.target.model.order());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    const double u_star = -ff.L.dot(x) - ff.target.L.dot(xr) + ff.target.feedthrough * u[k];
    EXPECT_NEAR(drive[k], u_star, 1e-9 * (1.0 + std::abs(u_star))) << k;
    const double y = ff.plant.C.dot(x) + ff.plant.D * u_star;
    EXPECT_NEAR(y_lin[k], y, 1e-9 * (1.0 + std::abs(y))) << k;
    x = ff.plant.A * x + ff.plant.B * u_star;
    xr = ff.target.model.A * xr + ff.target.model.B * u[k];
  }
}

TEST(LqTarget, ExcursionFallsAsTheCornerRisesAndIsTheDoubleIntegralOfTheDesiredResponse) {
  // The same noise and the same double leaky integral written out here: the estimate is max|∫∫ y_lin|.
  const LinearModel m = acceleration_model();
  const LqFeedforward ff = design_lq(m, {1e-4, 20.0}, {40.0, 2, 300.0});
  const Eigen::VectorXd y = simulate(ff.desired(), target_test_noise(5000, 7));
  const double lambda = std::exp(-2.0 * std::numbers::pi / 500.0);
  double v = 0.0, x = 0.0, peak = 0.0;
  for (Eigen::Index k = 0; k < y.size(); ++k) {
    v = lambda * v + y[k] / m.fs;
    x = lambda * x + v / m.fs;
    peak = std::max(peak, std::abs(x));
  }
  EXPECT_NEAR(noise_excursion(ff, {}, 5000, 7), peak, 1e-9 * peak);
  double previous = noise_excursion(design_lq(m, {1e-4, 20.0}), {}, 5000, 7);
  for (const double hz : {40.0, 80.0, 160.0}) {
    const double e = noise_excursion(design_lq(m, {1e-4, 20.0}, {hz, 2, 400.0}), {}, 5000, 7);
    EXPECT_LT(e, previous) << hz << " Hz";
    previous = e;
  }
  expect_invalid([&] { noise_excursion(ff, {}, 0, 7); }, "samples must be >= 1");
}

TEST(LqTarget, RefusesACornerOutsideTheBandAndBadOrders) {
  const LinearModel m = acceleration_model();
  expect_invalid([&] { design_lq(m, {1.0, 20.0}, {0.0, 2, 300.0}); }, "high-pass corner must be in (0, fs/2 = 1500) Hz, got 0");
  expect_invalid([&] { design_lq(m, {1.0, 20.0}, {1500.0, 2, 300.0}); }, "high-pass corner");
  expect_invalid([&] { design_lq(m, {1.0, 20.0}, {40.0, 2, 2000.0}); }, "mid-band frequency");
  expect_invalid([&] { design_lq(m, {1.0, 20.0}, {40.0, 0, 300.0}); }, "order must be in 1…8, got 0");
  expect_invalid([&] { design_lq(m, {1.0, 20.0}, {40.0, 9, 300.0}); }, "got 9");
  expect_invalid([&] { design_lq(m, {0.0, 20.0}, {40.0, 2, 300.0}); }, "R must be > 0");
}

TEST(LqTarget, JsonRecordsTheTargetAndReadsItBack) {
  const LinearModel m = acceleration_model();
  const LqFeedforward ff = design_lq(m, {1e-3, 20.0}, {40.0, 3, 300.0});
  const nlohmann::json j = lq_feedforward_to_json(ff);
  EXPECT_EQ(j["params"]["target"]["highpass_hz"], 40.0);
  EXPECT_EQ(j["params"]["target"]["order"], 3);
  const LqFeedforward back = lq_feedforward_from_json(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(back.target.model.A, ff.target.model.A);
  EXPECT_EQ(back.target.L, ff.target.L);
  EXPECT_EQ(back.target.feedthrough, ff.target.feedthrough);
  EXPECT_EQ(back.target.gain, ff.target.gain);
  for (const double f : {10.0, 100.0, 1000.0}) {
    EXPECT_EQ(response(back.controller(), f, m.fs), response(ff.controller(), f, m.fs));
  }
  nlohmann::json bad = j;
  bad["params"]["target"]["L"].erase(0);
  const std::string message = one_line_error<ConfigError>([&] { lq_feedforward_from_json(bad); });
  EXPECT_NE(message.find("model.params.target.L:"), std::string::npos) << message;
  EXPECT_FALSE(lq_feedforward_to_json(design_lq(m, {1e-3, 20.0}))["params"].contains("target"));
}

}  // namespace
}  // namespace panelbass::models

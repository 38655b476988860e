// LevenbergMarquardt against closed forms: the least-squares solution of a linear problem (from a QR
// factorisation, not from the optimiser), the Rosenbrock minimum (1, 1) from the standard start
// (−1.2, 1), a diagonal system's damped step δ_i = g_i / (H_ii + damping_i) for each damping rule, and λ's
// bookkeeping: ÷ factor after a success (not below its floor), × factor after each rejected (+∞) trial
// (not above its ceiling), held parameters, and no step for non-finite normal equations.
#include "models/optimization/levenberg_marquardt.h"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cmath>
#include <limits>

namespace panelbass::models {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// A linear least-squares problem r(θ) = A·θ − b with V = ½‖r‖²/M, H = AᵀA/M, g = Aᵀr/M.
struct LinearProblem {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;

  double loss(const Eigen::VectorXd& theta) const { return 0.5 * (A * theta - b).squaredNorm() / A.rows(); }
  Eigen::MatrixXd hessian() const { return A.transpose() * A / static_cast<double>(A.rows()); }
  Eigen::VectorXd gradient(const Eigen::VectorXd& theta) const {
    return A.transpose() * (A * theta - b) / static_cast<double>(A.rows());
  }
};

LinearProblem polynomial_fit() {
  // b(t) = fitted by 1, t, t², t³ at 40 points; the data are a cubic plus a deterministic wiggle so that the
  // residual at the optimum is not zero.
  LinearProblem p;
  const int M = 40;
  p.A.resize(M, 4);
  p.b.resize(M);
  for (int i = 0; i < M; ++i) {
    const double t = -1.0 + 2.0 * i / (M - 1);
    p.A.row(i) << 1.0, t, t * t, t * t * t;
    p.b[i] = 0.3 - 1.1 * t + 2.0 * t * t * t + 0.05 * std::sin(17.0 * t);
  }
  return p;
}

TEST(LevenbergMarquardt, ReachesTheClosedFormLeastSquaresSolutionOfALinearProblem) {
  const LinearProblem p = polynomial_fit();
  const Eigen::VectorXd expected = p.A.colPivHouseholderQr().solve(p.b);  // the closed form, by QR
  LevenbergMarquardt lm(LmSettings{}, 4);
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(4);
  int steps = 0;
  const auto trial = [&](const Eigen::VectorXd& c) { return p.loss(c); };
  for (; steps < 100; ++steps) {
    const LmStep s = lm.step(p.hessian(), p.gradient(theta), p.loss(theta), theta, trial);
    if (!s.accepted) break;
    EXPECT_DOUBLE_EQ(s.loss, p.loss(theta));  // the loss it reports is the loss at the new θ
  }
  EXPECT_LT(steps, 100);
  EXPECT_LT((theta - expected).cwiseAbs().maxCoeff(), 1e-9) << theta.transpose() << " vs " << expected.transpose();
}

TEST(LevenbergMarquardt, FindsTheRosenbrockMinimumFromTheStandardStart) {
  // f(x, y) = (1 − x)² + 100·(y − x²)² = r₁² + r₂², r₁ = 1 − x, r₂ = 10·(y − x²); minimum f = 0 at (1, 1).
  const auto residual = [](const Eigen::VectorXd& v) {
    return Eigen::Vector2d(1.0 - v[0], 10.0 * (v[1] - v[0] * v[0]));
  };
  const auto loss = [&](const Eigen::VectorXd& v) { return 0.5 * residual(v).squaredNorm(); };
  LevenbergMarquardt lm(LmSettings{.retries = 30}, 2);
  Eigen::VectorXd theta(2);
  theta << -1.2, 1.0;
  int steps = 0;
  for (; steps < 500; ++steps) {
    Eigen::Matrix2d J;
    J << -1.0, 0.0, -20.0 * theta[0], 10.0;
    const Eigen::MatrixXd H = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * residual(theta);
    if (!lm.step(H, g, loss(theta), theta, loss).accepted) break;
  }
  EXPECT_LT(steps, 500);
  EXPECT_NEAR(theta[0], 1.0, 1e-8);
  EXPECT_NEAR(theta[1], 1.0, 1e-8);
}

/// H = diag(4, 1, 0) (the third parameter unexcited), g = (2, −3, 0), λ = 0.5: the damped step per rule.
struct DiagonalCase {
  Eigen::MatrixXd H = Eigen::Vector3d(4.0, 1.0, 0.0).asDiagonal();
  Eigen::VectorXd g = Eigen::Vector3d(2.0, -3.0, 0.0);
  double lambda = 0.5;

  /// The candidate θ − δ the optimiser proposes first from θ = 0 (its trial rejects it).
  Eigen::VectorXd first_candidate(LmDamping damping) const {
    LevenbergMarquardt lm(LmSettings{.damping = damping, .initial_lambda = lambda, .retries = 1}, 3);
    Eigen::VectorXd theta = Eigen::VectorXd::Zero(3), seen;
    lm.step(H, g, 1.0, theta, [&](const Eigen::VectorXd& c) {
      seen = c;
      return kInf;
    });
    return seen;
  }
};

TEST(LevenbergMarquardt, EachDampingRuleSolvesItsDiagonalSystem) {
  const DiagonalCase d;
  const double largest = 4.0, mean = 5.0 / 3.0;
  // relative_to_largest: δ_i = g_i / (H_ii + λ·max(H_ii, 1e-12·largest))
  const Eigen::VectorXd a = d.first_candidate(LmDamping::relative_to_largest);
  EXPECT_DOUBLE_EQ(a[0], -2.0 / (4.0 + 0.5 * 4.0));
  EXPECT_DOUBLE_EQ(a[1], 3.0 / (1.0 + 0.5 * 1.0));
  EXPECT_EQ(a[2], 0.0);  // the floor keeps the unexcited parameter's system definite: its step is zero
  // relative_to_mean: δ_i = g_i / (H_ii + λ·(H_ii + 1e-9·mean))
  const Eigen::VectorXd b = d.first_candidate(LmDamping::relative_to_mean);
  EXPECT_DOUBLE_EQ(b[0], -2.0 / (4.0 + 0.5 * (4.0 + 1e-9 * mean)));
  EXPECT_DOUBLE_EQ(b[1], 3.0 / (1.0 + 0.5 * (1.0 + 1e-9 * mean)));
  EXPECT_EQ(b[2], 0.0);
  // relative_to_mean_with_ridge: δ_i = g_i / (H_ii + λ·(H_ii + 1e-9·mean) + 1e-12·(1 + largest))
  const Eigen::VectorXd c = d.first_candidate(LmDamping::relative_to_mean_with_ridge);
  const double ridge = 1e-12 * (1.0 + largest);
  EXPECT_DOUBLE_EQ(c[0], -2.0 / (4.0 + 0.5 * (4.0 + 1e-9 * mean) + ridge));
  EXPECT_DOUBLE_EQ(c[1], 3.0 / (1.0 + 0.5 * (1.0 + 1e-9 * mean) + ridge));
  EXPECT_EQ(c[2], 0.0);
}

TEST(LevenbergMarquardt, LambdaFallsByTheFactorAfterASuccessButNotBelowItsFloor) {
  const LinearProblem p = polynomial_fit();
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(4);
  const auto trial = [&](const Eigen::VectorXd& c) { return p.loss(c); };
  LevenbergMarquardt lm(LmSettings{.initial_lambda = 1e-3, .min_lambda = 1e-5}, 4);
  ASSERT_TRUE(lm.step(p.hessian(), p.gradient(theta), p.loss(theta), theta, trial).accepted);
  EXPECT_DOUBLE_EQ(lm.lambda(), 1e-4);
  ASSERT_TRUE(lm.step(p.hessian(), p.gradient(theta), p.loss(theta), theta, trial).accepted);
  EXPECT_DOUBLE_EQ(lm.lambda(), 1e-5);
  lm.step(p.hessian(), p.gradient(theta), p.loss(theta), theta, trial);
  EXPECT_GE(lm.lambda(), 1e-5);  // at the floor, or raised by a failure at the optimum
  lm.reset();
  EXPECT_DOUBLE_EQ(lm.lambda(), 1e-3);
}

TEST(LevenbergMarquardt, RejectsAnInfiniteTrialAndRaisesLambdaThenAcceptsTheNext) {
  const LinearProblem p = polynomial_fit();
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(4);
  LevenbergMarquardt lm(LmSettings{.initial_lambda = 1e-3, .factor = 10.0}, 4);
  int calls = 0;
  double lambda_at_second_call = 0.0;
  const LmStep s = lm.step(p.hessian(), p.gradient(theta), p.loss(theta), theta, [&](const Eigen::VectorXd& c) {
    if (++calls == 1) return kInf;  // e.g. an unstable candidate
    lambda_at_second_call = lm.lambda();
    return p.loss(c);
  });
  EXPECT_TRUE(s.accepted);
  EXPECT_EQ(calls, 2);
  EXPECT_DOUBLE_EQ(lambda_at_second_call, 1e-2);  // raised ×10 by the rejection
  EXPECT_DOUBLE_EQ(lm.lambda(), 1e-3);            // then ÷10 by the success
}

TEST(LevenbergMarquardt, GivesUpAfterItsRetriesWithLambdaRaisedToItsCeilingAndThetaKept) {
  const LinearProblem p = polynomial_fit();
  const Eigen::VectorXd start = Eigen::VectorXd::Constant(4, 0.25);
  Eigen::VectorXd theta = start;
  LevenbergMarquardt lm(LmSettings{.initial_lambda = 1e-3, .max_lambda = 1.0, .retries = 5}, 4);
  int calls = 0;
  const LmStep s = lm.step(p.hessian(), p.gradient(theta), p.loss(theta), theta, [&](const Eigen::VectorXd&) {
    ++calls;
    return kInf;
  });
  EXPECT_FALSE(s.accepted);
  EXPECT_DOUBLE_EQ(s.loss, p.loss(start));
  EXPECT_EQ(calls, 5);
  EXPECT_DOUBLE_EQ(lm.lambda(), 1.0);  // 1e-3 · 10³ = 1, then held at the ceiling
  EXPECT_EQ(theta, start);
}

TEST(LevenbergMarquardt, AHeldParameterDoesNotMove) {
  // Mask (1, 0, 1, 1): the held parameter's step is exactly zero; the others minimise with it fixed, which
  // for a linear problem is the least-squares solution over the free columns given the held value.
  const LinearProblem p = polynomial_fit();
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(4);
  theta[1] = 0.7;
  const Eigen::Vector4d mask(1.0, 0.0, 1.0, 1.0);
  LevenbergMarquardt lm(LmSettings{}, 4);
  for (int i = 0; i < 100; ++i) {
    Eigen::MatrixXd H = p.hessian();
    Eigen::VectorXd g = p.gradient(theta);
    // the reduced system: held rows and columns of H and entries of g zeroed, as the NARX trainer does
    H.array().colwise() *= mask.array();
    H.array().rowwise() *= mask.transpose().array();
    g.array() *= mask.array();
    if (!lm.step(H, g, p.loss(theta), theta, [&](const Eigen::VectorXd& c) { return p.loss(c); }, mask).accepted) break;
  }
  EXPECT_EQ(theta[1], 0.7);
  Eigen::MatrixXd free_columns(p.A.rows(), 3);
  free_columns << p.A.col(0), p.A.col(2), p.A.col(3);
  const Eigen::VectorXd expected = free_columns.colPivHouseholderQr().solve(p.b - 0.7 * p.A.col(1));
  EXPECT_NEAR(theta[0], expected[0], 1e-9);
  EXPECT_NEAR(theta[2], expected[1], 1e-9);
  EXPECT_NEAR(theta[3], expected[2], 1e-9);
}

TEST(LevenbergMarquardt, TakesNoStepFromNonFiniteNormalEquations) {
  Eigen::MatrixXd H = Eigen::MatrixXd::Identity(2, 2);
  Eigen::VectorXd g = Eigen::VectorXd::Ones(2), theta = Eigen::VectorXd::Zero(2);
  LevenbergMarquardt lm(LmSettings{.initial_lambda = 1e-3}, 2);
  int calls = 0;
  const auto trial = [&](const Eigen::VectorXd&) {
    ++calls;
    return 0.0;
  };
  H(0, 1) = std::nan("");
  EXPECT_FALSE(lm.step(H, g, 1.0, theta, trial).accepted);
  H(0, 1) = 0.0;
  g[1] = kInf;
  EXPECT_FALSE(lm.step(H, g, 1.0, theta, trial).accepted);
  g[1] = 1.0;
  EXPECT_FALSE(lm.step(H, g, kInf, theta, trial).accepted);
  EXPECT_EQ(calls, 0);
  EXPECT_DOUBLE_EQ(lm.lambda(), 1e-3);
  EXPECT_EQ(theta, Eigen::VectorXd::Zero(2));
}

}  // namespace
}  // namespace panelbass::models

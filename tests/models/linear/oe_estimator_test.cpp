// estimate_oe against finite-difference sensitivities and gradients, the bias of ARX under white
// output noise (OE is consistent, ARX is not), the parameter covariance σ²(ΨᵀΨ)⁻¹ of the theory,
// stability from an unstable start, the stop reasons, the transient skip, stabilized(), the errors.
#include "models/linear/oe_estimator.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <string>
#include <vector>

#include "dsp/excitation.h"
#include "dsp/random.h"
#include "models/linear/arx_estimator.h"
#include "models/linear/estimation_error.h"
#include "tests/support/expect_error.h"
#include "tests/support/linear_systems.h"

namespace panelbass::models {
namespace {

using testing_support::gaussian;
using testing_support::simulate;

Eigen::VectorXd theta_of(const TransferFunction& tf) {
  Eigen::VectorXd t(tf.na() + tf.nb());
  t << tf.a, tf.b;
  return t;
}

TransferFunction with_theta(TransferFunction tf, const Eigen::VectorXd& theta) {
  tf.a = theta.head(tf.na());
  tf.b = theta.tail(tf.nb());
  return tf;
}

/// A(q) with poles r·e^{±jw}.
Eigen::VectorXd resonant_a(double r, double w) { return Eigen::Vector2d(-2.0 * r * std::cos(w), r * r); }

/// The second-order OE system of the brief: poles 0.95·e^{±j0.4}, B = q⁻¹(0.1 + 0.05 q⁻¹).
TransferFunction second_order_truth() {
  TransferFunction t;
  t.a = resonant_a(0.95, 0.4);
  t.b = Eigen::Vector2d(0.1, 0.05);
  t.nk = 1;
  return t;
}

/// V = mean over k ≥ skip of (y − ŷ)², computed by the test's own simulation.
double loss(const TransferFunction& tf, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index skip) {
  const Eigen::Index M = y.size() - skip;
  return (y.tail(M) - simulate(tf, u).tail(M)).squaredNorm() / static_cast<double>(M);
}

std::string error_of(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const TransferFunction& init,
                     const OeOptions& o = {}) {
  return testing_support::message_of<EstimationError>([&] { estimate_oe(u, y, init, o); }, "(no error)");
}

TEST(OeEstimatorTest, JacobianMatchesCentralFiniteDifferencesOfTheSimulation) {
  const Eigen::VectorXd u = dsp::uniform_noise(300, 1.0, 1);
  TransferFunction tf;
  Eigen::VectorXd a(3);
  a << -1.2, 0.6, -0.1;
  tf.a = a;
  tf.b = Eigen::Vector3d(0.4, -0.1, 0.2);
  tf.nk = 2;
  const Eigen::MatrixXd J = oe_jacobian(u, tf);
  ASSERT_EQ(J.rows(), 300);
  ASSERT_EQ(J.cols(), 6);
  const Eigen::VectorXd theta = theta_of(tf);
  const double h = 1e-6;
  for (Eigen::Index p = 0; p < theta.size(); ++p) {
    // (ŷ(θ + h·e_p) − ŷ(θ − h·e_p)) / 2h, error O(h²)
    Eigen::VectorXd plus = theta, minus = theta;
    plus[p] += h;
    minus[p] -= h;
    const Eigen::VectorXd fd = (simulate(with_theta(tf, plus), u) - simulate(with_theta(tf, minus), u)) / (2.0 * h);
    EXPECT_LT((J.col(p) - fd).cwiseAbs().maxCoeff(), 1e-6 * fd.cwiseAbs().maxCoeff()) << "parameter " << p;
  }
}

TEST(OeEstimatorTest, LossGradientMatchesCentralFiniteDifferences) {
  // ∂V/∂θ = −(2/M)·Σ_{k≥skip} e(k)·∂ŷ(k)/∂θ, against central differences of V computed by the test.
  const TransferFunction truth = second_order_truth();
  const Eigen::VectorXd u = dsp::uniform_noise(500, 1.0, 2);
  const Eigen::VectorXd y = simulate(truth, u) + gaussian(500, 0.05, 3);
  TransferFunction at = truth;
  at.a = resonant_a(0.9, 0.5);
  at.b = Eigen::Vector2d(0.12, 0.02);
  const Eigen::Index skip = 25, M = 500 - skip;
  const Eigen::MatrixXd J = oe_jacobian(u, at);
  const Eigen::VectorXd e = y - simulate(at, u);
  const Eigen::VectorXd grad = -2.0 / static_cast<double>(M) * J.bottomRows(M).transpose() * e.tail(M);
  const Eigen::VectorXd theta = theta_of(at);
  const double h = 1e-6;
  for (Eigen::Index p = 0; p < theta.size(); ++p) {
    Eigen::VectorXd plus = theta, minus = theta;
    plus[p] += h;
    minus[p] -= h;
    const double fd = (loss(with_theta(at, plus), u, y, skip) - loss(with_theta(at, minus), u, y, skip)) / (2.0 * h);
    EXPECT_NEAR(grad[p], fd, 1e-6 * std::max(1.0, std::abs(fd))) << "parameter " << p;
  }
}

TEST(OeEstimatorTest, LossAndHistoryAreTheMeanSquaredSimulationError) {
  const TransferFunction truth = second_order_truth();
  const Eigen::VectorXd u = dsp::uniform_noise(1000, 1.0, 4);
  const Eigen::VectorXd y = simulate(truth, u) + gaussian(1000, 0.1, 5);
  TransferFunction start = truth;
  start.a = resonant_a(0.9, 0.5);
  OeOptions o;
  o.transient_skip = 40;
  const OeResult r = estimate_oe(u, y, start, o);
  ASSERT_GE(r.history.size(), 2u);
  EXPECT_NEAR(r.history.front(), loss(start, u, y, 40), 1e-12);
  EXPECT_NEAR(r.loss, loss(r.tf, u, y, 40), 1e-12);
  EXPECT_EQ(r.history.back(), r.loss);
  EXPECT_EQ(r.history.size(), static_cast<std::size_t>(r.iterations) + 1);
  for (std::size_t i = 1; i < r.history.size(); ++i) EXPECT_LT(r.history[i], r.history[i - 1]) << "iteration " << i;
}

TEST(OeEstimatorTest, RecoversOeSystemWithWhiteOutputNoiseWhereArxIsBiased) {
  // y = B/A·u + v with white v (σ = 0.15, about 30 % of the output's rms). The OE estimate is
  // consistent: its error is compared with the asymptotic covariance σ²(ΨᵀΨ)⁻¹ (Ljung, eq. 9.18). ARX
  // sees the coloured equation error A·v and is biased.
  const TransferFunction truth = second_order_truth();
  const Eigen::Index N = 4000;
  const Eigen::VectorXd u = dsp::uniform_noise(N, 1.0, 7);
  const Eigen::VectorXd y = simulate(truth, u) + gaussian(N, 0.15, 8);
  const TransferFunction arx = estimate_arx(u, y, {2, 2, 1});
  const OeResult oe = estimate_oe(u, y, stabilized(arx));
  EXPECT_EQ(oe.stop_reason, "converged");
  EXPECT_TRUE(oe.converged);
  EXPECT_TRUE(oe.tf.is_stable());
  EXPECT_NEAR(oe.loss, 0.15 * 0.15, 0.1 * 0.15 * 0.15);  // the noise variance, within its sampling spread

  const Eigen::VectorXd theta0 = theta_of(truth);
  const Eigen::VectorXd oe_error = theta_of(oe.tf) - theta0;
  const Eigen::MatrixXd J = oe_jacobian(u, oe.tf);
  const Eigen::MatrixXd covariance = oe.loss * (J.transpose() * J).inverse();
  for (Eigen::Index p = 0; p < 4; ++p) {
    EXPECT_LT(std::abs(oe_error[p]), 4.0 * std::sqrt(covariance(p, p))) << "parameter " << p;
  }
  const double arx_error = (theta_of(arx) - theta0).norm();
  EXPECT_GT(arx_error, 5.0 * oe_error.norm()) << "ARX error " << arx_error << ", OE error " << oe_error.norm();
}

TEST(OeEstimatorTest, UnstableStartEndsStableAtTheSameOptimum) {
  const TransferFunction truth = second_order_truth();
  const Eigen::VectorXd u = dsp::uniform_noise(4000, 1.0, 7);
  const Eigen::VectorXd y = simulate(truth, u) + gaussian(4000, 0.15, 8);
  TransferFunction unstable = truth;
  unstable.a = resonant_a(1.2, 0.7);
  unstable.b = Eigen::Vector2d(0.1, 0.1);
  ASSERT_FALSE(unstable.is_stable());
  const OeResult from_unstable = estimate_oe(u, y, unstable);
  const OeResult from_arx = estimate_oe(u, y, stabilized(estimate_arx(u, y, {2, 2, 1})));
  EXPECT_TRUE(from_unstable.tf.is_stable(1e-6));
  EXPECT_EQ(from_unstable.stop_reason, "converged");
  EXPECT_LT((theta_of(from_unstable.tf) - theta_of(from_arx.tf)).norm(), 1e-4);
  // history[0] is the loss of the reflected start, not of the unstable one (which has none).
  EXPECT_NEAR(from_unstable.history.front(), loss(stabilized(unstable), u, y, 0), 1e-12);
}

TEST(OeEstimatorTest, EveryAcceptedStepKeepsThePolesInsideTheMargin) {
  // A margin of 0.1 keeps the poles inside radius 0.9, while the truth's lie at 0.95: the fit presses
  // against the constraint and every iterate (hence the result) stays inside it.
  const TransferFunction truth = second_order_truth();
  const Eigen::VectorXd u = dsp::uniform_noise(2000, 1.0, 9);
  const Eigen::VectorXd y = simulate(truth, u);
  TransferFunction start = truth;
  start.a = resonant_a(0.5, 0.4);
  OeOptions o;
  o.stability_margin = 0.1;
  o.max_iterations = 60;
  const OeResult r = estimate_oe(u, y, start, o);
  EXPECT_TRUE(r.tf.is_stable(0.1));
  EXPECT_GT(r.tf.poles().cwiseAbs().maxCoeff(), 0.85);  // it did move towards the truth
  EXPECT_LT(r.loss, r.history.front());
}

TEST(OeEstimatorTest, StopsAtMaxIterationsAndReportsProgress) {
  const TransferFunction truth = second_order_truth();
  const Eigen::VectorXd u = dsp::uniform_noise(1000, 1.0, 10);
  const Eigen::VectorXd y = simulate(truth, u) + gaussian(1000, 0.1, 11);
  TransferFunction start = truth;
  start.a = resonant_a(0.8, 0.6);
  std::vector<std::pair<int, double>> calls;
  OeOptions o;
  o.max_iterations = 2;
  o.progress = [&](int iteration, double l) { calls.emplace_back(iteration, l); };
  const OeResult r = estimate_oe(u, y, start, o);
  EXPECT_EQ(r.stop_reason, "max_iterations");
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.iterations, 2);
  ASSERT_EQ(r.history.size(), 3u);
  ASSERT_EQ(calls.size(), 2u);
  EXPECT_EQ(calls[0].first, 1);
  EXPECT_EQ(calls[1].first, 2);
  EXPECT_EQ(calls[0].second, r.history[1]);
  EXPECT_EQ(calls[1].second, r.history[2]);

  o.max_iterations = 0;
  const OeResult none = estimate_oe(u, y, start, o);
  EXPECT_EQ(none.stop_reason, "max_iterations");
  EXPECT_EQ(none.iterations, 0);
  ASSERT_EQ(none.history.size(), 1u);
  EXPECT_EQ(theta_of(none.tf), theta_of(start));
}

TEST(OeEstimatorTest, ConvergesOnSmallRelativeImprovement) {
  const TransferFunction truth = second_order_truth();
  const Eigen::VectorXd u = dsp::uniform_noise(1000, 1.0, 10);
  const Eigen::VectorXd y = simulate(truth, u) + gaussian(1000, 0.1, 11);
  TransferFunction start = truth;
  start.a = resonant_a(0.8, 0.6);
  OeOptions o;
  o.tolerance = 1e-6;
  const OeResult r = estimate_oe(u, y, start, o);
  EXPECT_EQ(r.stop_reason, "converged");
  EXPECT_TRUE(r.converged);
  ASSERT_GE(r.history.size(), 2u);
  const double last = r.history[r.history.size() - 1], before = r.history[r.history.size() - 2];
  EXPECT_LT((before - last) / before, 1e-6);
  for (std::size_t i = 1; i + 1 < r.history.size(); ++i) {
    EXPECT_GE((r.history[i - 1] - r.history[i]) / r.history[i - 1], 1e-6) << "stopped late at " << i;
  }
}

TEST(OeEstimatorTest, ToleranceZeroRunsUntilNoStepDescends) {
  // Only a strict decrease is accepted, so with tolerance 0 the fit runs to the rounding floor and
  // ends when no damping gives a step that lowers the loss.
  const TransferFunction truth = second_order_truth();
  const Eigen::VectorXd u = dsp::uniform_noise(1000, 1.0, 12);
  const Eigen::VectorXd y = simulate(truth, u) + gaussian(1000, 0.1, 13);
  OeOptions o;
  o.tolerance = 0.0;
  o.max_iterations = 500;
  const OeResult r = estimate_oe(u, y, stabilized(estimate_arx(u, y, {2, 2, 1})), o);
  EXPECT_EQ(r.stop_reason, "no_descent");
  EXPECT_FALSE(r.converged);
  EXPECT_LT(r.iterations, 500);
  const OeResult normal = estimate_oe(u, y, stabilized(estimate_arx(u, y, {2, 2, 1})));
  EXPECT_LE(r.loss, normal.loss);
  EXPECT_NEAR(r.loss, normal.loss, 1e-6 * normal.loss);
}

TEST(OeEstimatorTest, ExactStartOnNoiseFreeDataIsConvergedAtOnce) {
  const TransferFunction truth = second_order_truth();
  const Eigen::VectorXd u = dsp::uniform_noise(500, 1.0, 14);
  const OeResult r = estimate_oe(u, simulate(truth, u), truth);
  EXPECT_EQ(r.stop_reason, "converged");
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(r.loss, 0.0);
}

TEST(OeEstimatorTest, RecoversNoiseFreeSystemExactly) {
  const TransferFunction truth = second_order_truth();
  const Eigen::VectorXd u = dsp::uniform_noise(1000, 1.0, 15);
  TransferFunction start = truth;
  start.a = resonant_a(0.7, 0.6);
  start.b = Eigen::Vector2d(0.2, 0.0);
  const OeResult r = estimate_oe(u, simulate(truth, u), start);
  EXPECT_LT((theta_of(r.tf) - theta_of(truth)).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(OeEstimatorTest, TransientSkipLeavesTheStartOutOfTheLoss) {
  // Noise-free output except for the first 30 samples, which are garbage: skipping them recovers the
  // truth exactly, fitting them does not.
  const TransferFunction truth = second_order_truth();
  const Eigen::VectorXd u = dsp::uniform_noise(1000, 1.0, 16);
  Eigen::VectorXd y = simulate(truth, u);
  y.head(30) = gaussian(30, 5.0, 17);
  TransferFunction start = truth;
  start.a = resonant_a(0.8, 0.5);
  OeOptions o;
  o.transient_skip = 30;
  const OeResult skipped = estimate_oe(u, y, start, o);
  EXPECT_LT((theta_of(skipped.tf) - theta_of(truth)).cwiseAbs().maxCoeff(), 1e-8);
  const OeResult fitted = estimate_oe(u, y, start);
  EXPECT_GT((theta_of(fitted.tf) - theta_of(truth)).cwiseAbs().maxCoeff(), 1e-4);
}

TEST(OeEstimatorTest, StabilizedReflectsUnstablePolesAndKeepsB) {
  // Poles 1.25·e^{±j0.5} and 0.5: the pair goes to 0.8·e^{±j0.5}, 0.5 stays, B is untouched, and the
  // magnitude is multiplied by |p|² = 1.5625 at every frequency (|e^{jω} − p| = |p|·|e^{jω} − 1/p̄|).
  Eigen::VectorXcd p(3);
  p << std::polar(1.25, 0.5), std::polar(1.25, -0.5), 0.5;
  TransferFunction tf;
  tf.a = polynomial_from_roots(p).tail(3);
  tf.b = Eigen::Vector2d(1.0, 0.3);
  tf.nk = 1;
  const TransferFunction s = stabilized(tf);
  EXPECT_TRUE(s.is_stable(1e-6));
  EXPECT_EQ(s.b, tf.b);
  EXPECT_EQ(s.nk, 1);
  Eigen::VectorXcd expected(3);
  expected << std::polar(0.8, 0.5), std::polar(0.8, -0.5), 0.5;
  const Eigen::VectorXd expected_a = polynomial_from_roots(expected).tail(3);
  EXPECT_LT((s.a - expected_a).cwiseAbs().maxCoeff(), 1e-12);
  for (double f : {0.0, 0.05, 0.1, 0.2, 0.3, 0.45}) {
    EXPECT_NEAR(std::abs(s.response(f, 1.0)), 1.5625 * std::abs(tf.response(f, 1.0)),
                1e-9 * std::abs(s.response(f, 1.0)))
        << "f = " << f;
  }
}

TEST(OeEstimatorTest, StabilizedPullsPolesOnTheCircleInsideTheMarginAndLeavesStableModelsAlone) {
  TransferFunction integrator;  // pole at z = 1
  integrator.a = Eigen::VectorXd::Constant(1, -1.0);
  integrator.b = Eigen::VectorXd::Constant(1, 1.0);
  const TransferFunction s = stabilized(integrator, 1e-3);
  EXPECT_TRUE(s.is_stable(1e-3));
  EXPECT_GT(std::abs(s.poles()[0]), 0.99);

  TransferFunction double_pole;  // (1 − 1.1q⁻¹)²: a repeated pole outside, reflected to 1/1.1 twice
  double_pole.a = Eigen::Vector2d(-2.2, 1.21);
  double_pole.b = Eigen::VectorXd::Constant(1, 1.0);
  const TransferFunction d = stabilized(double_pole);
  EXPECT_TRUE(d.is_stable(1e-6));
  EXPECT_NEAR(d.a[0], -2.0 / 1.1, 1e-6);
  EXPECT_NEAR(d.a[1], 1.0 / 1.21, 1e-6);

  const TransferFunction stable = second_order_truth();
  const TransferFunction same = stabilized(stable);
  EXPECT_EQ(same.a, stable.a);
  EXPECT_EQ(same.b, stable.b);
}

TEST(OeEstimatorTest, RejectsUnusableDataWithMessages) {
  const TransferFunction start = second_order_truth();
  const Eigen::VectorXd u = dsp::uniform_noise(100, 1.0, 20), y = gaussian(100, 1.0, 21);
  EXPECT_EQ(error_of(u, gaussian(99, 1.0, 22), start),
            "OE(na=2, nb=2, nk=1): the input has 100 samples but the output has 99");
  Eigen::VectorXd bad = u;
  bad[17] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(error_of(bad, y, start), "OE(na=2, nb=2, nk=1): the input has a non-finite value at sample 17");
  bad = y;
  bad[3] = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(error_of(u, bad, start), "OE(na=2, nb=2, nk=1): the output has a non-finite value at sample 3");
  EXPECT_EQ(error_of(Eigen::VectorXd::Constant(100, 0.2), y, start), "OE(na=2, nb=2, nk=1): the input is constant");
  OeOptions o;
  o.transient_skip = 96;
  EXPECT_EQ(error_of(u, y, start, o),
            "OE(na=2, nb=2, nk=1): 4 samples after a transient skip of 96 are too few for 4 parameters");
  o.transient_skip = 200;
  EXPECT_EQ(error_of(u, y, start, o),
            "OE(na=2, nb=2, nk=1): 0 samples after a transient skip of 200 are too few for 4 parameters");
  o.transient_skip = -1;
  EXPECT_EQ(error_of(u, y, start, o), "OE(na=2, nb=2, nk=1): the transient skip must not be negative");
}

TEST(OeEstimatorTest, RejectsBadInitialModelsAndOptions) {
  const Eigen::VectorXd u = dsp::uniform_noise(100, 1.0, 23), y = gaussian(100, 1.0, 24);
  TransferFunction no_b;
  no_b.a = resonant_a(0.5, 0.5);
  EXPECT_EQ(error_of(u, y, no_b), "OE(na=2, nb=0, nk=0): the initial model has no numerator coefficients");
  TransferFunction nan_a = second_order_truth();
  nan_a.a[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(error_of(u, y, nan_a), "OE(na=2, nb=2, nk=1): the initial model has a non-finite coefficient");
  TransferFunction negative_delay = second_order_truth();
  negative_delay.nk = -1;
  EXPECT_EQ(error_of(u, y, negative_delay), "OE(na=2, nb=2, nk=-1): the input delay must not be negative");
  OeOptions o;
  o.max_iterations = -1;
  EXPECT_EQ(error_of(u, y, second_order_truth(), o), "OE(na=2, nb=2, nk=1): max_iterations must not be negative");
  o = {};
  o.stability_margin = 1.0;
  EXPECT_EQ(error_of(u, y, second_order_truth(), o), "OE(na=2, nb=2, nk=1): the stability margin must lie in [0, 1)");
  o = {};
  o.tolerance = -1.0;
  EXPECT_EQ(error_of(u, y, second_order_truth(), o), "OE(na=2, nb=2, nk=1): the tolerance must not be negative");
}

}  // namespace
}  // namespace panelbass::models

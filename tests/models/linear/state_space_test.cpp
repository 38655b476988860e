// State-space realisation, balancing, conversion back, simulation and initial-state estimation, each
// checked against a computation written out here: polynomial responses (TransferFunction::response),
// plain difference equations (double and long double), Gramians summed as series, and closed forms.
#include "models/linear/state_space.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include "dsp/excitation.h"
#include "tests/support/vectors.h"
#include "tests/support/linear_systems.h"

namespace panelbass::models {
namespace {

using testing_support::vec;

// `count` roots in conjugate pairs, radius uniform in [r_min, r_max], angle uniform in (θ0, θ1)·π.
Eigen::VectorXcd conjugate_pairs(int count, double r_min, double r_max, double th0, double th1, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::VectorXcd roots(count);
  for (int i = 0; i + 1 < count; i += 2) {
    const double r = r_min + (r_max - r_min) * unit(rng);
    const double th = std::numbers::pi * (th0 + (th1 - th0) * unit(rng));
    roots[i] = std::polar(r, th);
    roots[i + 1] = std::conj(roots[i]);
  }
  return roots;
}

// The 4th-order example used by several tests: poles 0.9∠±0.3 and 0.7∠±1.2, a direct term b_0 ≠ 0.
TransferFunction fourth_order(int nk = 0) {
  TransferFunction tf;
  Eigen::VectorXcd poles(4);
  poles << std::polar(0.9, 0.3), std::polar(0.9, -0.3), std::polar(0.7, 1.2), std::polar(0.7, -1.2);
  tf.a = testing_support::denominator(poles);
  tf.b = vec({0.5, -0.2, 0.3, 0.1});
  tf.nk = nk;
  return tf;
}

// y(k) = −Σ a_i·y(k−i) + Σ b_j·u(k−nk−j), at rest before k = 0, in arithmetic of type Scalar.
template <typename Scalar>
std::vector<Scalar> direct_form(const TransferFunction& tf, const Eigen::VectorXd& u) {
  std::vector<Scalar> y(static_cast<std::size_t>(u.size()), Scalar(0));
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    Scalar acc = 0;
    for (Eigen::Index j = 0; j < tf.nb(); ++j) {
      const Eigen::Index t = k - tf.nk - j;
      if (t >= 0) acc += static_cast<Scalar>(tf.b[j]) * static_cast<Scalar>(u[t]);
    }
    for (Eigen::Index i = 1; i <= tf.na(); ++i) {
      if (k - i >= 0) acc -= static_cast<Scalar>(tf.a[i - 1]) * y[static_cast<std::size_t>(k - i)];
    }
    y[static_cast<std::size_t>(k)] = acc;
  }
  return y;
}

// Largest |H_ss − H_tf| / |H_tf| over `points` frequencies spread over (0, fs/2).
double worst_relative_response_error(const StateSpace& ss, const TransferFunction& tf, int points) {
  const double fs = 3000.0;
  double worst = 0.0;
  for (int i = 0; i < points; ++i) {
    const double f = 0.5 * fs * (i + 0.5) / points;
    const std::complex<double> expected = tf.response(f, fs);
    worst = std::max(worst, std::abs(response(ss, f, fs) - expected) / std::abs(expected));
  }
  return worst;
}

// Σ_k M^k·Q·(M^k)ᵀ summed until the terms stop mattering: the Gramian as its defining series.
Eigen::MatrixXd gramian_by_series(const Eigen::MatrixXd& M, const Eigen::MatrixXd& Q) {
  Eigen::MatrixXd sum = Q, term = Q;
  for (int k = 0; k < 100000; ++k) {
    term = M * term * M.transpose();
    sum += term;
    if (term.norm() < 1e-22 * sum.norm()) break;
  }
  return sum;
}

TEST(StateSpaceTest, LowOrderResponseMatchesTransferFunction) {
  const TransferFunction tf = fourth_order();
  const StateSpace ss = realize(tf);
  EXPECT_EQ(ss.order(), 4);
  EXPECT_DOUBLE_EQ(ss.D, 0.5);  // b_0 with no delay is the direct feedthrough
  EXPECT_LT(worst_relative_response_error(ss, tf, 500), 1e-9);
}

TEST(StateSpaceTest, ThirtiethOrderResponseMatchesTransferFunction) {
  // Random stable poles up to radius 0.99; zeros well inside the circle so that |H| has no deep
  // notches, where any relative comparison would measure rounding of the reference itself.
  TransferFunction tf;
  tf.a = testing_support::denominator(conjugate_pairs(30, 0.2, 0.99, 0.0, 1.0, 21));
  tf.b = 0.01 * polynomial_from_roots(conjugate_pairs(28, 0.0, 0.5, 0.0, 1.0, 22));
  tf.nk = 1;
  ASSERT_TRUE(tf.is_stable());
  const StateSpace ss = realize(tf);
  EXPECT_LT(worst_relative_response_error(ss, tf, 2000), 1e-9);
}

TEST(StateSpaceTest, DelayBecomesExtraStates) {
  const TransferFunction tf = fourth_order(3);
  const StateSpace ss = realize(tf);
  // max(na, nk + nb − 1) = max(4, 3 + 4 − 1) = 6 states; no direct term behind a delay.
  EXPECT_EQ(ss.order(), 6);
  EXPECT_EQ(ss.D, 0.0);
  EXPECT_LT(worst_relative_response_error(ss, tf, 500), 1e-9);
}

TEST(StateSpaceTest, FirResponseAndSimulation) {
  TransferFunction tf;
  tf.a.resize(0);
  tf.b = vec({0.3, -0.5, 0.8, 0.25, -0.1, 0.05, 0.02, -0.01});
  tf.nk = 2;
  const StateSpace ss = realize(tf);
  EXPECT_EQ(ss.order(), 9);
  EXPECT_LT(worst_relative_response_error(ss, tf, 500), 1e-9);
  // An FIR is a convolution: y(k) = Σ b_j·u(k − 2 − j).
  const Eigen::VectorXd u = dsp::uniform_noise(200, 1.0, 5);
  const Eigen::VectorXd y = simulate(ss, u);
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    double expected = 0.0;
    for (Eigen::Index j = 0; j < tf.nb(); ++j) {
      if (k - 2 - j >= 0) expected += tf.b[j] * u[k - 2 - j];
    }
    ASSERT_NEAR(y[k], expected, 1e-12) << "k = " << k;
  }
}

TEST(StateSpaceTest, PureGainHasNoStates) {
  TransferFunction tf;
  tf.a.resize(0);
  tf.b = vec({2.5});
  const StateSpace ss = realize(tf);
  EXPECT_EQ(ss.order(), 0);
  EXPECT_EQ(ss.D, 2.5);
  EXPECT_EQ(response(ss, 123.0, 3000.0), std::complex<double>(2.5, 0.0));
  const Eigen::VectorXd u = dsp::uniform_noise(50, 1.0, 6);
  EXPECT_TRUE(simulate(ss, u).isApprox(2.5 * u));
}

TEST(StateSpaceTest, DelayedGainIsAShiftRegister) {
  TransferFunction tf;
  tf.a.resize(0);
  tf.b = vec({2.5});
  tf.nk = 3;
  const StateSpace ss = realize(tf);
  EXPECT_EQ(ss.order(), 3);
  // H = 2.5·e^{−3jω}
  const double omega = 2.0 * std::numbers::pi * 400.0 / 3000.0;
  EXPECT_LT(std::abs(response(ss, 400.0, 3000.0) - 2.5 * std::polar(1.0, -3.0 * omega)), 1e-12);
  const Eigen::VectorXd u = dsp::uniform_noise(50, 1.0, 7);
  const Eigen::VectorXd y = simulate(ss, u);
  for (Eigen::Index k = 0; k < 3; ++k) EXPECT_NEAR(y[k], 0.0, 1e-15);
  for (Eigen::Index k = 3; k < u.size(); ++k) EXPECT_NEAR(y[k], 2.5 * u[k - 3], 1e-13);
}

TEST(StateSpaceTest, ZeroNumeratorIsZeroSystem) {
  TransferFunction tf = fourth_order();
  tf.b = vec({0.0, 0.0});
  const StateSpace ss = realize(tf);
  EXPECT_EQ(ss.order(), 0);
  EXPECT_EQ(ss.D, 0.0);
}

TEST(StateSpaceTest, UnstableModelIsRealisedWithoutBalancing) {
  TransferFunction tf;
  Eigen::VectorXcd poles(2);
  poles << std::polar(1.05, 0.4), std::polar(1.05, -0.4);
  tf.a = testing_support::denominator(poles);
  tf.b = vec({1.0, 0.5});
  const StateSpace ss = realize(tf);
  EXPECT_EQ(ss.order(), 2);
  EXPECT_LT(worst_relative_response_error(ss, tf, 300), 1e-12);
}

TEST(StateSpaceTest, RealizeRejectsNonFiniteCoefficients) {
  TransferFunction tf = fourth_order();
  tf.a[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(realize(tf), std::invalid_argument);
  tf = fourth_order();
  tf.b[0] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(realize(tf), std::invalid_argument);
}

TEST(StateSpaceTest, SimulationMatchesDirectFormDifferenceEquation) {
  for (int nk : {0, 2}) {
    const TransferFunction tf = fourth_order(nk);
    const Eigen::VectorXd u = dsp::uniform_noise(2000, 1.0, 8);
    const Eigen::VectorXd y = simulate(realize(tf), u);
    const std::vector<double> expected = direct_form<double>(tf, u);
    for (Eigen::Index k = 0; k < u.size(); ++k) {
      ASSERT_NEAR(y[k], expected[static_cast<std::size_t>(k)], 1e-10) << "nk = " << nk << ", k = " << k;
    }
  }
}

TEST(StateSpaceTest, HighOrderSimulationStaysAccurateWhereDirectFormDrifts) {
  // 30 poles at radius 0.999 between 0.1π and 0.7π: Σ|a_i| ≈ 5e5, so each direct-form step rounds a
  // sum far larger than its result and 1/A(q) then rings that rounding for thousands of samples. The
  // reference is the same recursion in long double (x86: 11 more mantissa bits), whose own error is
  // about 2000 times smaller than the double recursion's.
  constexpr int kOrder = 30;
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::VectorXcd poles(kOrder);
  for (int i = 0; i < kOrder; i += 2) {  // one pair per angle stratum
    const double th = std::numbers::pi * (0.1 + 0.6 * (i / 2 + 0.5 * unit(rng)) / (kOrder / 2));
    poles[i] = std::polar(0.999, th);
    poles[i + 1] = std::conj(poles[i]);
  }
  TransferFunction tf;
  tf.a = testing_support::denominator(poles);
  tf.b = vec({1.0});
  ASSERT_GT(tf.a.cwiseAbs().sum(), 1e5);

  const Eigen::VectorXd u = dsp::uniform_noise(20000, 1.0, 9);
  const std::vector<long double> reference = direct_form<long double>(tf, u);
  const std::vector<double> direct = direct_form<double>(tf, u);
  const Eigen::VectorXd y = simulate(realize(tf), u);
  double peak = 0.0, state_space_error = 0.0, direct_error = 0.0;
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    const auto i = static_cast<std::size_t>(k);
    peak = std::max(peak, static_cast<double>(std::abs(reference[i])));
    state_space_error = std::max(state_space_error, static_cast<double>(std::abs(y[k] - reference[i])));
    direct_error = std::max(direct_error, static_cast<double>(std::abs(direct[i] - reference[i])));
  }
  EXPECT_LT(state_space_error, 1e-9 * peak);
  EXPECT_GT(direct_error, 10.0 * state_space_error);
}

TEST(StateSpaceTest, PolynomialTooIllConditionedToBalanceIsNoWorseThanDirectForm) {
  // 30 poles at radius 0.99 crowded into 0.05π…0.5π: Σ|a_i| ≈ 3e7, and the Gramians of the companion
  // form span more decades than long double resolves. realize() must then keep the canonical form
  // rather than return a balanced model that has drifted (or gone unstable); its simulation is then as
  // good as the direct form's, which here is itself off by about 0.2 %.
  constexpr int kOrder = 30;
  std::mt19937_64 rng(61);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::VectorXcd poles(kOrder);
  for (int i = 0; i < kOrder; i += 2) {
    const double th = std::numbers::pi * (0.05 + 0.45 * (i / 2 + 0.5 * unit(rng)) / (kOrder / 2));
    poles[i] = std::polar(0.99, th);
    poles[i + 1] = std::conj(poles[i]);
  }
  TransferFunction tf;
  tf.a = testing_support::denominator(poles);
  tf.b = vec({1.0});
  ASSERT_GT(tf.a.cwiseAbs().sum(), 1e7);

  const Eigen::VectorXd u = dsp::uniform_noise(20000, 1.0, 62);
  const std::vector<long double> reference = direct_form<long double>(tf, u);
  const std::vector<double> direct = direct_form<double>(tf, u);
  const Eigen::VectorXd y = simulate(realize(tf), u);
  ASSERT_TRUE(y.allFinite());
  double state_space_error = 0.0, direct_error = 0.0;
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    const auto i = static_cast<std::size_t>(k);
    state_space_error = std::max(state_space_error, static_cast<double>(std::abs(y[k] - reference[i])));
    direct_error = std::max(direct_error, static_cast<double>(std::abs(direct[i] - reference[i])));
  }
  EXPECT_LT(state_space_error, 3.0 * direct_error);
}

TEST(StateSpaceTest, BalancedGramiansAreEqualAndDiagonal) {
  const StateSpace ss = realize(fourth_order());
  Eigen::VectorXd hsv;
  const StateSpace balanced = balance(ss, &hsv);
  ASSERT_EQ(hsv.size(), 4);
  // Wc = Σ A^k·B·Bᵀ·(A^k)ᵀ,  Wo = Σ (A^k)ᵀ·Cᵀ·C·A^k, summed here independently of the solver.
  const Eigen::MatrixXd Wc = gramian_by_series(balanced.A, balanced.B * balanced.B.transpose());
  const Eigen::MatrixXd Wo = gramian_by_series(balanced.A.transpose(), balanced.C.transpose() * balanced.C);
  const Eigen::MatrixXd expected = hsv.asDiagonal();
  EXPECT_LT((Wc - expected).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((Wo - expected).cwiseAbs().maxCoeff(), 1e-8);
  // realize() already balances a stable model.
  const Eigen::MatrixXd Wc_realized = gramian_by_series(ss.A, ss.B * ss.B.transpose());
  EXPECT_LT((Wc_realized - expected).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(StateSpaceTest, HankelSingularValuesMatchSeriesGramians) {
  // An unbalanced realisation built by hand: the controllable canonical form of the 4th-order model,
  // x1(k+1) = −Σ a_i x_i(k) + u(k), x_{i+1}(k+1) = x_i(k), y = Σ (b_i − b_0 a_i)·x_i + b_0·u.
  const TransferFunction tf = fourth_order();
  StateSpace ss;
  ss.A = Eigen::MatrixXd::Zero(4, 4);
  ss.A.row(0) = -tf.a.transpose();
  ss.A.diagonal(-1).setOnes();
  ss.B = Eigen::VectorXd::Unit(4, 0);
  ss.C = (tf.b.tail(3) - tf.b[0] * tf.a.head(3)).transpose();
  ss.C.conservativeResize(4);
  ss.C[3] = -tf.b[0] * tf.a[3];
  ss.D = tf.b[0];
  ASSERT_LT(worst_relative_response_error(ss, tf, 200), 1e-12);  // the hand realisation is right

  // σ_i = √λ_i(Wc·Wo), Gramians summed as series.
  const Eigen::MatrixXd Wc = gramian_by_series(ss.A, ss.B * ss.B.transpose());
  const Eigen::MatrixXd Wo = gramian_by_series(ss.A.transpose(), ss.C.transpose() * ss.C);
  Eigen::VectorXd expected = Eigen::EigenSolver<Eigen::MatrixXd>(Wc * Wo, false).eigenvalues().real().cwiseSqrt();
  std::sort(expected.data(), expected.data() + expected.size(), std::greater<double>());

  Eigen::VectorXd hsv;
  const StateSpace balanced = balance(ss, &hsv);
  ASSERT_EQ(hsv.size(), 4);
  for (Eigen::Index i = 0; i < 4; ++i) EXPECT_NEAR(hsv[i], expected[i], 1e-8 * expected[0]) << "i = " << i;
  EXPECT_LT(worst_relative_response_error(balanced, tf, 300), 1e-10);  // same system
}

TEST(StateSpaceTest, BalanceRejectsUnstableSystem) {
  StateSpace ss;
  ss.A = Eigen::MatrixXd::Constant(1, 1, 1.1);
  ss.B = vec({1.0});
  ss.C = Eigen::RowVectorXd::Constant(1, 1.0);
  EXPECT_THROW(balance(ss), std::invalid_argument);
}

TEST(StateSpaceTest, BalanceRejectsNonMinimalSystem) {
  // The second mode is never excited (B_2 = 0): Wc is singular.
  StateSpace ss;
  ss.A = vec({0.5, -0.3}).asDiagonal();
  ss.B = vec({1.0, 0.0});
  ss.C = vec({1.0, 1.0}).transpose();
  EXPECT_THROW(balance(ss), std::invalid_argument);
  // ... and unobservable (C_2 = 0).
  ss.B = vec({1.0, 1.0});
  ss.C = vec({1.0, 0.0}).transpose();
  EXPECT_THROW(balance(ss), std::invalid_argument);
}

TEST(StateSpaceTest, ToTransferFunctionOfClosedFormExample) {
  // H = 3 + 2/(z − 0.5) = (3 + 0.5 z⁻¹)/(1 − 0.5 z⁻¹).
  StateSpace ss;
  ss.A = Eigen::MatrixXd::Constant(1, 1, 0.5);
  ss.B = vec({1.0});
  ss.C = Eigen::RowVectorXd::Constant(1, 2.0);
  ss.D = 3.0;
  const TransferFunction tf = to_transfer_function(ss);
  ASSERT_EQ(tf.na(), 1);
  ASSERT_EQ(tf.nb(), 2);
  EXPECT_NEAR(tf.a[0], -0.5, 1e-15);
  EXPECT_NEAR(tf.b[0], 3.0, 1e-15);
  EXPECT_NEAR(tf.b[1], 0.5, 1e-15);
  EXPECT_EQ(tf.nk, 0);
}

TEST(StateSpaceTest, ToTransferFunctionRecoversCoefficients) {
  TransferFunction tf;
  tf.a = testing_support::denominator(conjugate_pairs(6, 0.4, 0.95, 0.05, 0.95, 41));
  tf.b = vec({0.4, -0.3, 0.2, 0.5, -0.1, 0.05, 0.3});
  const TransferFunction back = to_transfer_function(realize(tf));
  ASSERT_EQ(back.na(), 6);
  ASSERT_EQ(back.nb(), 7);
  EXPECT_EQ(back.nk, 0);
  EXPECT_LT((back.a - tf.a).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((back.b - tf.b).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(StateSpaceTest, ToTransferFunctionKeepsDelayAsLeadingZeros) {
  const TransferFunction tf = fourth_order(2);  // max(4, 2 + 4 − 1) = 5 states
  const TransferFunction back = to_transfer_function(realize(tf));
  ASSERT_EQ(back.na(), 5);
  ASSERT_EQ(back.nb(), 6);
  // q⁻²·B(q)/A(q) over a common degree 5, A padded with one zero: b = [0, 0, b_0..b_3].
  const Eigen::VectorXd expected_b = vec({0.0, 0.0, 0.5, -0.2, 0.3, 0.1});
  Eigen::VectorXd expected_a = Eigen::VectorXd::Zero(5);
  expected_a.head(4) = tf.a;
  EXPECT_LT((back.a - expected_a).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((back.b - expected_b).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(StateSpaceTest, InitialStateRecoversKnownState) {
  TransferFunction tf;
  tf.a = testing_support::denominator(conjugate_pairs(6, 0.5, 0.95, 0.05, 0.95, 51));
  tf.b = vec({0.2, 0.4, -0.3});
  tf.nk = 1;
  const StateSpace ss = realize(tf);
  ASSERT_EQ(ss.order(), 6);
  const Eigen::VectorXd x0 = vec({0.8, -0.5, 0.3, 1.2, -0.7, 0.4});
  const Eigen::VectorXd u = dsp::uniform_noise(400, 1.0, 52);
  const Eigen::VectorXd y = simulate(ss, u, x0);
  const Eigen::VectorXd estimate = initial_state(ss, u, y, 50);
  EXPECT_LT((estimate - x0).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((simulate(ss, u, estimate) - y).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(StateSpaceTest, InitialStateNeedsAtLeastOrderSamples) {
  const StateSpace ss = realize(fourth_order());
  const Eigen::VectorXd u = dsp::uniform_noise(100, 1.0, 53);
  const Eigen::VectorXd y = simulate(ss, u);
  EXPECT_THROW(initial_state(ss, u, y, 3), std::invalid_argument);
  EXPECT_NO_THROW(initial_state(ss, u, y, 4));
  EXPECT_THROW(initial_state(ss, u, y, 101), std::invalid_argument);
}

TEST(StateSpaceTest, SimulateRejectsWrongInitialStateSize) {
  const StateSpace ss = realize(fourth_order());
  EXPECT_THROW(simulate(ss, Eigen::VectorXd::Zero(10), Eigen::VectorXd::Zero(3)), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

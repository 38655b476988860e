// Billings–Voon residual tests on residuals whose structure is known by construction: white noise
// independent of u passes everything; c·u² added fails φ_u²'ε (even order); the odd part of c·u³ that a
// linear model leaves (u³ − β·u, β = E[u⁴]/E[u²]) fails φ_u²'ε² only; filtered noise fails φ_εε only.
// The correlations themselves are checked against the definitions written out as plain sums, and the
// chance allowance against the binomial distribution summed from its pmf.
#include "models/validation/residual_tests.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dsp/excitation.h"
#include "tests/support/expect_error.h"
#include "tests/support/linear_systems.h"

namespace panelbass::models {
namespace {

using testing_support::expect_invalid;
using testing_support::gaussian;

constexpr Eigen::Index kN = 3000;
constexpr int kLags = 20;

Eigen::VectorXd input() { return dsp::uniform_noise(kN, 1.0, 7); }

bool mentions(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

// (1/√(Σa'²·Σb'²))·Σ_t a'(t−τ)·b'(t) with a' = a − ā, b' = b − b̄, written out index by index.
double phi(const Eigen::VectorXd& a, const Eigen::VectorXd& b, int tau) {
  const double ma = a.mean(), mb = b.mean();
  double s = 0.0, saa = 0.0, sbb = 0.0;
  for (Eigen::Index t = 0; t < a.size(); ++t) {
    saa += (a[t] - ma) * (a[t] - ma);
    sbb += (b[t] - mb) * (b[t] - mb);
    if (t - tau >= 0 && t - tau < a.size()) s += (a[t - tau] - ma) * (b[t] - mb);
  }
  return s / std::sqrt(saa * sbb);
}

TEST(ResidualTestsTest, WhiteIndependentResidualPassesAll) {
  const Eigen::VectorXd u = input();
  const Eigen::VectorXd e = gaussian(kN, 0.1, 99);
  const ResidualTests r = residual_tests(u, e, kLags);
  for (const CorrelationTest* t : {&r.ee, &r.ue, &r.u2e, &r.u2e2, &r.e_eu}) {
    EXPECT_TRUE(t->passes) << t->name << ": " << t->outside << " outside, peak " << t->peak << " vs " << t->peak_band;
    EXPECT_NEAR(t->band, 1.96 / std::sqrt(static_cast<double>(kN)), 1e-4);
    EXPECT_GT(t->peak_band, t->band);
  }
  EXPECT_TRUE(r.passes);
  EXPECT_TRUE(r.input_tests_pass);
  EXPECT_TRUE(mentions(r.explanation, "white")) << r.explanation;
}

TEST(ResidualTestsTest, CorrelationsFollowTheirDefinitions) {
  const Eigen::VectorXd u = input().head(400);
  const Eigen::VectorXd e = gaussian(400, 0.1, 5) + 0.2 * u.array().square().matrix();
  const ResidualTests r = residual_tests(u, e, 5);
  ASSERT_EQ(r.ee.lags.front(), 1);
  ASSERT_EQ(r.ue.lags.front(), -5);
  ASSERT_EQ(r.e_eu.lags.front(), 0);
  const Eigen::VectorXd u2 = u.array().square(), e2 = e.array().square(), eu = e.cwiseProduct(u);
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(r.ee.values[i], phi(e, e, i + 1), 1e-12);
  for (int i = 0; i < 11; ++i) {
    const int tau = i - 5;
    EXPECT_NEAR(r.ue.values[i], phi(u, e, tau), 1e-12) << tau;
    EXPECT_NEAR(r.u2e.values[i], phi(u2, e, tau), 1e-12) << tau;
    EXPECT_NEAR(r.u2e2.values[i], phi(u2, e2, tau), 1e-12) << tau;
  }
  // φ_ε(εu)(τ) = E[ε(t)·ε(t−1−τ)·u(t−1−τ)]
  for (int tau = 0; tau <= 5; ++tau) EXPECT_NEAR(r.e_eu.values[tau], phi(eu, e, tau + 1), 1e-12) << tau;
}

TEST(ResidualTestsTest, ChanceAllowanceIsTheBinomialQuantile) {
  const ResidualTests r = residual_tests(input(), gaussian(kN, 0.1, 3), kLags);
  // Smallest c with P(Binomial(L, 0.05) ≤ c) ≥ 0.999, the pmf from log-gamma.
  for (const CorrelationTest* t : {&r.ee, &r.ue}) {
    const int lags = static_cast<int>(t->lags.size());
    double cdf = 0.0;
    int c = -1;
    while (cdf < 0.999) {
      ++c;
      cdf += std::exp(std::lgamma(lags + 1.0) - std::lgamma(c + 1.0) - std::lgamma(lags - c + 1.0) +
                      c * std::log(0.05) + (lags - c) * std::log(0.95));
    }
    EXPECT_EQ(t->allowed_outside, c) << t->name;
  }
  EXPECT_EQ(r.ee.allowed_outside, 5);   // 20 lags
  EXPECT_EQ(r.ue.allowed_outside, 7);   // 41 lags
}

TEST(ResidualTestsTest, SquaredInputInResidualFailsEvenOrderTest) {
  const Eigen::VectorXd u = input();
  const Eigen::VectorXd e = gaussian(kN, 0.1, 99) + 0.05 * u.array().square().matrix();
  const ResidualTests r = residual_tests(u, e, kLags);
  EXPECT_FALSE(r.u2e.passes);
  // At τ = 0: c·var(u²)/√(var(u²)·(c²·var(u²) + σ²)), var(u²) = E[u⁴] − E[u²]² = 1/5 − 1/9 for uniform u.
  const double var_u2 = 1.0 / 5.0 - 1.0 / 9.0;
  const double expected = 0.05 * var_u2 / std::sqrt(var_u2 * (0.05 * 0.05 * var_u2 + 0.01));
  EXPECT_NEAR(r.u2e.values[kLags], expected, 3.0 / std::sqrt(static_cast<double>(kN)));
  EXPECT_GT(r.u2e.values[kLags], r.u2e.peak_band);
  EXPECT_TRUE(r.ue.passes);  // u is symmetric: E[u·u²] = 0
  EXPECT_FALSE(r.passes);
  EXPECT_FALSE(r.input_tests_pass);
  EXPECT_TRUE(mentions(r.explanation, "u² → unmodelled even-order nonlinearity")) << r.explanation;
}

TEST(ResidualTestsTest, CubicLeftByALinearModelFailsOddOrderTest) {
  const Eigen::VectorXd u = input();
  // For uniform u on [−1, 1]: E[u⁴]/E[u²] = (1/5)/(1/3) = 0.6, the gain a linear model absorbs.
  const Eigen::VectorXd odd = u.array().cube() - 0.6 * u.array();
  const Eigen::VectorXd e = gaussian(kN, 0.02, 99) + 0.3 * odd;
  const ResidualTests r = residual_tests(u, e, kLags);
  EXPECT_FALSE(r.u2e2.passes);
  EXPECT_TRUE(r.ue.passes) << r.ue.peak;
  EXPECT_TRUE(r.u2e.passes) << r.u2e.peak;
  EXPECT_TRUE(mentions(r.explanation, "odd-order")) << r.explanation;
}

TEST(ResidualTestsTest, FilteredNoiseFailsWhitenessOnly) {
  const Eigen::VectorXd u = input();
  // ε(t) = 0.7·ε(t−1) + e(t): φ_εε(τ) = 0.7^τ
  TransferFunction ar;
  ar.a = Eigen::VectorXd::Constant(1, -0.7);
  ar.b = Eigen::VectorXd::Ones(1);
  const Eigen::VectorXd e = testing_support::simulate(ar, gaussian(kN, 0.1, 99));
  const ResidualTests r = residual_tests(u, e, kLags);
  EXPECT_FALSE(r.ee.passes);
  EXPECT_NEAR(r.ee.values[0], 0.7, 0.05);
  EXPECT_TRUE(r.input_tests_pass);
  EXPECT_FALSE(r.passes);
  EXPECT_TRUE(mentions(r.explanation, "coloured")) << r.explanation;
  EXPECT_FALSE(mentions(r.explanation, "u²")) << r.explanation;
}

TEST(ResidualTestsTest, RejectsBadArguments) {
  const Eigen::VectorXd u = input();
  const Eigen::VectorXd e = gaussian(kN, 0.1, 1);
  expect_invalid([&] { residual_tests(u, e.head(kN - 1), kLags); }, "samples");
  expect_invalid([&] { residual_tests(u, e, 0); }, "max lag");
  expect_invalid([&] { residual_tests(u.head(50), e.head(50), kLags); }, "too few");
  expect_invalid([&] { residual_tests(Eigen::VectorXd::Ones(kN), e, kLags); }, "u is constant");
  expect_invalid([&] { residual_tests(u, Eigen::VectorXd::Zero(kN), kLags); }, "residual is constant");
  Eigen::VectorXd bad = e;
  bad[10] = std::nan("");
  expect_invalid([&] { residual_tests(u, bad, kLags); }, "non-finite");
}

}  // namespace
}  // namespace panelbass::models

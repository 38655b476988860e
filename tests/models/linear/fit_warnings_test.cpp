// fit_warnings: a model no better than an output of zero (J ≥ 100 %) or than a linear model is said so;
// linear_reference_j_pct on a known linear plant (a first-order filter, exactly Zhu-identifiable) is tiny.

#include "models/linear/fit_warnings.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace panelbass::models {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(FitWarnings, AModelNoBetterThanZeroIsSaidSoWithTheAdvice) {
  const std::vector<std::string> w = fit_warnings(100.3, "J_val", kNaN, "Check the delay.");
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("no better than an output of zero"), std::string::npos) << w[0];
  EXPECT_NE(w[0].find("J_val = 100 %"), std::string::npos) << w[0];
  EXPECT_NE(w[0].find("Check the delay."), std::string::npos) << w[0];
  EXPECT_EQ(fit_warnings(kNaN, "J_val", kNaN, "x").size(), 1u) << "a diverged simulation is said so";
}

TEST(FitWarnings, WorseThanTheLinearModelIsSaidSoAndBetterIsNot) {
  const std::vector<std::string> w = fit_warnings(12.8, "J_val", 3.5, "More iterations.");
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("worse than a linear model"), std::string::npos) << w[0];
  EXPECT_NE(w[0].find("3.5 %"), std::string::npos) << w[0];
  EXPECT_TRUE(fit_warnings(2.0, "J_val", 3.5, "x").empty());
  EXPECT_TRUE(fit_warnings(2.0, "J_val", kNaN, "x").empty()) << "no linear model to compare: only the zero check";
  EXPECT_EQ(fit_warnings(120.0, "J_est", 50.0, "x").size(), 2u);
}

TEST(FitWarnings, TheLinearReferenceFitsALinearPlant) {
  // y(k) = 0.8·y(k−1) + 0.5·u(k−1) + small white noise: the reference (order 1, nk 1) fits it down to the noise.
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Index N = 4000;
  Eigen::VectorXd u(N), y(N);
  double state = 0.0;
  for (Eigen::Index k = 0; k < N; ++k) {
    u[k] = n(rng);
    y[k] = state + 0.01 * n(rng);
    state = 0.8 * state + 0.5 * u[k];
  }
  const double j = linear_reference_j_pct(u.head(3000), y.head(3000), u.tail(1000), y.tail(1000), 1, 1, 50);
  EXPECT_LT(j, 0.1);  // noise power 1e-4 over output power ~0.69: J ≈ 0.015 %
}

}  // namespace
}  // namespace panelbass::models

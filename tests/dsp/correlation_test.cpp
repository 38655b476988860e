// Normalised correlation functions against a brute-force double loop, the peak of a delayed copy,
// the noise band's coverage for independent white signals (a stated statistic with a fixed seed) and
// its closed form z/√N, and the argument checks.
#include "dsp/correlation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "dsp/excitation.h"
#include "dsp/random.h"
#include "tests/support/noise.h"

namespace panelbass::dsp {
namespace {

using testing_support::gaussian;
/// r(τ) = Σ_{k=0}^{N−1−τ} (u(k)−ū)(y(k+τ)−ȳ) / sqrt(Σ(u−ū)² Σ(y−ȳ)²), written out plainly.
std::vector<double> brute_xcorr(const Eigen::VectorXd& u, const Eigen::VectorXd& y, int max_lag) {
  const int n = static_cast<int>(u.size());
  double mu = 0.0, my = 0.0;
  for (int k = 0; k < n; ++k) {
    mu += u[k];
    my += y[k];
  }
  mu /= n;
  my /= n;
  double su = 0.0, sy = 0.0;
  for (int k = 0; k < n; ++k) {
    su += (u[k] - mu) * (u[k] - mu);
    sy += (y[k] - my) * (y[k] - my);
  }
  std::vector<double> r(static_cast<std::size_t>(max_lag + 1), 0.0);
  for (int tau = 0; tau <= max_lag; ++tau) {
    double s = 0.0;
    for (int k = 0; k + tau < n; ++k) s += (u[k] - mu) * (y[k + tau] - my);
    r[static_cast<std::size_t>(tau)] = s / std::sqrt(su * sy);
  }
  return r;
}

TEST(CorrelationTest, CrossCorrelationMatchesBruteForce) {
  // Non-zero means on purpose: both are removed.
  const Eigen::VectorXd u = uniform_noise(300, 1.0, 21).array() + 0.4;
  Eigen::VectorXd y(300);
  for (Eigen::Index k = 0; k < 300; ++k) y[k] = (k >= 2 ? 0.7 * u[k - 2] : 0.0) + 0.2 * std::sin(0.05 * k) - 1.3;
  const Eigen::VectorXd r = cross_correlation(u, y, 299);
  const std::vector<double> ref = brute_xcorr(u, y, 299);
  ASSERT_EQ(r.size(), 300);
  for (int tau = 0; tau <= 299; ++tau) EXPECT_NEAR(r[tau], ref[static_cast<std::size_t>(tau)], 1e-12) << tau;
}

TEST(CorrelationTest, CrossCorrelationIsInvariantToScaleAndOffset) {
  const Eigen::VectorXd u = uniform_noise(200, 1.0, 22);
  const Eigen::VectorXd y = uniform_noise(200, 1.0, 23);
  const Eigen::VectorXd r1 = cross_correlation(u, y, 20);
  const Eigen::VectorXd r2 = cross_correlation((3.0 * u).array() + 5.0, (0.1 * y).array() - 2.0, 20);
  for (Eigen::Index t = 0; t <= 20; ++t) EXPECT_NEAR(r1[t], r2[t], 1e-12);
}

TEST(CorrelationTest, AutocorrelationAtZeroIsOne) {
  const Eigen::VectorXd x = uniform_noise(1000, 0.3, 24).array() + 2.0;
  const Eigen::VectorXd r = autocorrelation(x, 10);
  EXPECT_NEAR(r[0], 1.0, 1e-14);
  const std::vector<double> ref = brute_xcorr(x, x, 10);
  for (int t = 0; t <= 10; ++t) EXPECT_NEAR(r[t], ref[static_cast<std::size_t>(t)], 1e-12);
}

TEST(CorrelationTest, DelayedCopyPeaksAtItsDelay) {
  const Eigen::Index n = 10000;
  const Eigen::VectorXd u = gaussian(n, 1.0, 25);
  Eigen::VectorXd y = Eigen::VectorXd::Zero(n);
  y.tail(n - 3) = u.head(n - 3);
  const Eigen::VectorXd r = cross_correlation(u, y, 20);
  Eigen::Index peak = 0;
  r.cwiseAbs().maxCoeff(&peak);
  EXPECT_EQ(peak, 3);
  // All but the last three of u's samples overlap their copy: r(3) ≈ sqrt((N−3)/N) ≈ 1 − 1.5e-4.
  EXPECT_NEAR(r[3], 1.0, 2e-3);
  // Every other lag holds only the input's sample autocorrelation: within the 99.99 % band (3.89/√N).
  for (Eigen::Index t = 0; t <= 20; ++t) {
    if (t != 3) {
      EXPECT_LT(std::abs(r[t]), 3.89 / std::sqrt(static_cast<double>(n))) << t;
    }
  }
}

TEST(CorrelationTest, IndependentWhiteSignalsStayInsideTheBand) {
  // For independent white signals r(τ) ≈ N(0, (N−τ)/N²) (the sum at lag τ has N−τ terms over N), so
  // P(|r(τ)| ≤ z/√N) = erf(z·sqrt(N/(N−τ))/√2). Averaged over lags 0..L that is the expected coverage;
  // with ~4000 lags its binomial standard deviation is sqrt(0.01·0.99/4000) ≈ 0.0016, and lags of one
  // pair are only weakly dependent. Tolerance 0.006 (≈ 4 σ), fixed seeds.
  const Eigen::Index n = 20000, max_lag = 199;
  const int pairs = 20;
  const double band = correlation_noise_band(n, 0.99);
  const double z = band * std::sqrt(static_cast<double>(n));
  double expected = 0.0;
  for (Eigen::Index t = 0; t <= max_lag; ++t) {
    expected += std::erf(z * std::sqrt(static_cast<double>(n) / static_cast<double>(n - t)) / std::sqrt(2.0));
  }
  expected /= static_cast<double>(max_lag + 1);
  int inside = 0, total = 0;
  for (int p = 0; p < pairs; ++p) {
    const Eigen::VectorXd u = gaussian(n, 1.0, 1000 + 2 * p);
    const Eigen::VectorXd y = gaussian(n, 1.0, 1001 + 2 * p);
    const Eigen::VectorXd r = cross_correlation(u, y, max_lag);
    for (Eigen::Index t = 0; t <= max_lag; ++t) {
      inside += std::abs(r[t]) <= band ? 1 : 0;
      ++total;
    }
  }
  const double fraction = static_cast<double>(inside) / total;
  EXPECT_GT(expected, 0.99);
  EXPECT_LT(expected, 0.992);
  EXPECT_NEAR(fraction, expected, 0.006) << inside << " of " << total;
}

TEST(CorrelationTest, NoiseBandIsNormalQuantileOverRootN) {
  for (Eigen::Index n : {100, 2000, 10000}) {
    const double rn = std::sqrt(static_cast<double>(n));
    EXPECT_NEAR(correlation_noise_band(n, 0.99) * rn, 2.5758, 1e-3) << n;
    EXPECT_NEAR(correlation_noise_band(n) * rn, 2.5758, 1e-3) << n;
    EXPECT_NEAR(correlation_noise_band(n, 0.95) * rn, 1.9600, 1e-3) << n;
    EXPECT_NEAR(correlation_noise_band(n, 0.999) * rn, 3.2905, 1e-3) << n;
  }
  EXPECT_THROW(correlation_noise_band(0), std::invalid_argument);
  EXPECT_THROW(correlation_noise_band(100, 0.0), std::invalid_argument);
  EXPECT_THROW(correlation_noise_band(100, 1.0), std::invalid_argument);
}

TEST(CorrelationTest, ThrowsForConstantSignal) {
  const Eigen::VectorXd u = uniform_noise(100, 1.0, 26);
  const Eigen::VectorXd c = Eigen::VectorXd::Constant(100, 0.5);
  EXPECT_THROW(cross_correlation(u, c, 10), std::invalid_argument);
  EXPECT_THROW(cross_correlation(c, u, 10), std::invalid_argument);
  EXPECT_THROW(autocorrelation(c, 10), std::invalid_argument);
  EXPECT_THROW(autocorrelation(Eigen::VectorXd::Zero(100), 10), std::invalid_argument);
}

TEST(CorrelationTest, ThrowsForMaxLagNotBelowLength) {
  const Eigen::VectorXd u = uniform_noise(100, 1.0, 27);
  EXPECT_NO_THROW(cross_correlation(u, u, 99));
  EXPECT_THROW(cross_correlation(u, u, 100), std::invalid_argument);
  EXPECT_THROW(cross_correlation(u, u, 500), std::invalid_argument);
  EXPECT_THROW(autocorrelation(u, 100), std::invalid_argument);
  EXPECT_THROW(cross_correlation(u, u, -1), std::invalid_argument);
}

TEST(CorrelationTest, ThrowsForUnequalLengths) {
  EXPECT_THROW(cross_correlation(uniform_noise(100, 1.0, 28), uniform_noise(101, 1.0, 29), 10), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::dsp

// Root locus of constant-gain output feedback against independent expectations: k = 0 returns the open
// loop's poles (TransferFunction::poles, plus the delay's poles at the origin); the thesis's fig 4.2
// second-order model G = b0·(1 − q⁻¹)·q⁻¹ / (1 + a1·q⁻¹ + a2·q⁻²) (a zero at DC, a resonance) has the
// closed-form closed-loop poles of z² + (a1 + k·b0)·z + (a2 − k·b0) and its shortest impulse response at
// the breakaway gain where that quadratic has a double root; the search agrees with brute force on a
// fine grid; the impulse-length definition agrees with a simulated first-order loop.
#include "models/control/root_locus.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include "tests/support/expect_error.h"
#include "tests/support/vectors.h"

namespace panelbass::models {
namespace {

using testing_support::expect_invalid;
using testing_support::vec;
using Complex = std::complex<double>;

// 150 Hz resonance at fs = 3000 Hz, pole radius 0.99 (the thesis's badly damped main resonance).
constexpr double kRadius = 0.99, kB0 = 0.05;
const double kTheta = 2.0 * std::numbers::pi * 150.0 / 3000.0;

TransferFunction second_order() {
  TransferFunction g;
  g.a = vec({-2.0 * kRadius * std::cos(kTheta), kRadius * kRadius});
  g.b = vec({kB0, -kB0});
  g.nk = 1;
  return g;
}

// Roots of z² + p·z + q by the quadratic formula.
std::vector<Complex> quadratic_roots(double p, double q) {
  const Complex s = std::sqrt(Complex(p * p - 4.0 * q, 0.0));
  return {(-p + s) / 2.0, (-p - s) / 2.0};
}

TEST(RootLocusTest, ZeroGainGivesOpenLoopPoles) {
  TransferFunction g;
  g.a = vec({-1.2, 0.9, -0.3, 0.1});
  g.b = vec({0.4, 0.2, -0.1});
  g.nk = 3;  // n = max(4, 3 + 3 − 1) = 5: one pole at the origin beyond the four of A
  const ClosedLoop loop = closed_loop(g, 0.0);
  const Eigen::VectorXcd open = g.poles();
  ASSERT_EQ(loop.poles.size(), 5);
  for (Eigen::Index i = 0; i < 4; ++i) EXPECT_EQ(loop.poles[i], open[i]);
  EXPECT_EQ(loop.poles[4], Complex(0.0, 0.0));
  EXPECT_EQ(loop.stable, g.is_stable());
  EXPECT_DOUBLE_EQ(loop.max_radius, open.cwiseAbs().maxCoeff());

  g.nk = 1;  // n = na = 4: no extra poles
  const ClosedLoop short_delay = closed_loop(g, 0.0);
  ASSERT_EQ(short_delay.poles.size(), 4);
  for (Eigen::Index i = 0; i < 4; ++i) EXPECT_EQ(short_delay.poles[i], open[i]);
}

TEST(RootLocusTest, SecondOrderPolesMatchClosedForm) {
  const TransferFunction g = second_order();
  const std::vector<double> gains = {-3.0, 0.0, 2.0, 7.5, 10.0, 20.0, 30.0, 45.0};
  const std::vector<ClosedLoop> locus = root_locus(g, gains);
  ASSERT_EQ(locus.size(), gains.size());
  for (std::size_t i = 0; i < gains.size(); ++i) {
    const double k = gains[i];
    const auto expected = quadratic_roots(g.a[0] + k * kB0, g.a[1] - k * kB0);
    ASSERT_EQ(locus[i].poles.size(), 2);
    EXPECT_EQ(locus[i].gain, k);
    for (const Complex& e : expected) {
      const double nearest = std::min(std::abs(locus[i].poles[0] - e), std::abs(locus[i].poles[1] - e));
      EXPECT_LT(nearest, 1e-10) << "k = " << k << ", expected pole " << e;
    }
    const double radius = std::max(std::abs(expected[0]), std::abs(expected[1]));
    EXPECT_NEAR(locus[i].max_radius, radius, 1e-10);
    EXPECT_EQ(locus[i].stable, radius < 1.0) << "k = " << k;
  }
  EXPECT_TRUE(locus[1].stable);
  EXPECT_FALSE(locus.back().stable);  // k = 45: one pole has left through −1
  EXPECT_TRUE(std::isinf(locus.back().impulse_length));
}

TEST(RootLocusTest, ShortestImpulseAtBreakawayGainAndMatchesBruteForce) {
  const TransferFunction g = second_order();
  const double k_max = 30.0;
  const ShortestImpulse found = shortest_impulse_gain(g, 0.0, k_max, 31);
  ASSERT_EQ(found.grid.size(), 31u);

  // Brute force: every gain on a grid 10⁴ times finer.
  const int fine = 300001;
  double brute_gain = 0.0, brute_radius = 1e300;
  for (int i = 0; i < fine; ++i) {
    const double k = k_max * i / (fine - 1);
    const double r = closed_loop(g, k).max_radius;
    if (r < brute_radius) brute_radius = r, brute_gain = k;
  }
  EXPECT_NEAR(found.best.gain, brute_gain, 2.0 * k_max / (fine - 1));
  EXPECT_LE(found.best.max_radius, brute_radius + 1e-9);

  // Breakaway: (a1 + k·b0)² = 4·(a2 − k·b0), i.e. b0²k² + (2a1 + 4)·b0·k + a1² − 4a2 = 0, the positive root.
  const double a1 = g.a[0], a2 = g.a[1];
  const double qa = kB0 * kB0, qb = (2.0 * a1 + 4.0) * kB0, qc = a1 * a1 - 4.0 * a2;
  const double breakaway = (-qb + std::sqrt(qb * qb - 4.0 * qa * qc)) / (2.0 * qa);
  EXPECT_NEAR(found.best.gain, breakaway, 1e-6 * breakaway);
  EXPECT_NEAR(found.best.max_radius, std::sqrt(a2 - breakaway * kB0), 1e-7);
  EXPECT_TRUE(found.best.stable);
  // Much shorter than the open loop's ln(0.01)/ln(0.99) ≈ 458 samples.
  EXPECT_NEAR(closed_loop(g, 0.0).impulse_length, std::log(0.01) / std::log(kRadius), 1e-9);
  EXPECT_LT(found.best.impulse_length, 15.0);
}

TEST(RootLocusTest, ImpulseLengthIsWhenASimulatedLoopFallsBelowOnePercent) {
  // y(t) = 0.95·y(t−1) + 0.5·u(t−1), u = r − k·y: closed-loop pole 0.95 − 0.5·k.
  TransferFunction g;
  g.a = vec({-0.95});
  g.b = vec({0.5});
  g.nk = 1;
  const double k = 0.3;
  const ClosedLoop loop = closed_loop(g, k);
  ASSERT_EQ(loop.poles.size(), 1);
  EXPECT_NEAR(loop.poles[0].real(), 0.8, 1e-15);
  // The loop's impulse response, simulated: the last sample at or above 1 % of the peak.
  std::vector<double> y(200, 0.0);
  double u_prev = 1.0;  // r = δ(t) at t = 0, y(0) = 0
  for (std::size_t t = 1; t < y.size(); ++t) {
    y[t] = 0.95 * y[t - 1] + 0.5 * u_prev;
    u_prev = -k * y[t];
  }
  const double peak = *std::max_element(y.begin(), y.end());
  std::size_t last = 0;
  for (std::size_t t = 0; t < y.size(); ++t) {
    if (std::abs(y[t]) >= 0.01 * peak) last = t;
  }
  // The peak is at t = 1, so the response is at 1 % after `impulse_length` samples more.
  EXPECT_EQ(last, 1 + static_cast<std::size_t>(std::floor(loop.impulse_length)));
}

TEST(RootLocusTest, ModelGainsAreInRawUnits) {
  LinearModel model;
  model.tf = second_order();
  model.fs = 3000.0;
  model.scaling.u_scale = 0.5;
  model.scaling.y_scale = 2.0;
  const std::vector<ClosedLoop> raw = root_locus(model, {0.0, 1.0, 2.5});
  ASSERT_EQ(raw.size(), 3u);
  for (const ClosedLoop& loop : raw) {
    const ClosedLoop scaled = closed_loop(model.tf, loop.gain * 4.0);  // k·y_scale/u_scale
    EXPECT_EQ(loop.poles, scaled.poles) << loop.gain;
  }
  EXPECT_EQ(raw[1].gain, 1.0);
}

TEST(RootLocusTest, AlgebraicLoopThatVanishesIsIllPosed) {
  TransferFunction g;
  g.a = vec({-0.5});
  g.b = vec({2.0, 1.0});
  g.nk = 0;  // c_0 = 1 + 2k = 0 at k = −0.5
  const ClosedLoop loop = closed_loop(g, -0.5);
  EXPECT_FALSE(loop.stable);
  EXPECT_TRUE(std::isinf(loop.impulse_length));
  EXPECT_EQ(loop.poles.size(), 0);
  EXPECT_TRUE(closed_loop(g, 0.1).stable);  // (1 + 0.2)·z + (−0.5 + 0.1): pole 1/3
  EXPECT_NEAR(closed_loop(g, 0.1).poles[0].real(), 0.4 / 1.2, 1e-15);
}

TEST(RootLocusTest, RejectsBadArguments) {
  const TransferFunction g = second_order();
  expect_invalid([&] { shortest_impulse_gain(g, 1.0, 1.0); }, "k_min < k_max");
  expect_invalid([&] { shortest_impulse_gain(g, 0.0, 1.0, 2); }, "grid points");
  expect_invalid([&] { closed_loop(g, std::nan("")); }, "gain must be finite");
  TransferFunction bad = g;
  bad.a[1] = std::nan("");
  expect_invalid([&] { closed_loop(bad, 1.0); }, "non-finite");
}

}  // namespace
}  // namespace panelbass::models

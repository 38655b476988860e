// The best linear approximation against independent expectations: a linear filter's BLA is its
// frequency response (closed form of the difference equation); the noise variance matches the variance
// that known white output noise puts on Y/U (N·σ²/|U(k)|², averaged); a static x + a·x² after a filter
// shows distortion at the even detection lines only, x + b·x³ at the odd ones only, and its BLA is the
// filter times Bussgang's gain 1 + 3b·σ_x² (Gaussian limit of a many-line random-phase multisine).
#include "dsp/best_linear_approximation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "dsp/random.h"
#include "tests/support/expect_error.h"
#include "tests/support/noise.h"

namespace panelbass::dsp {
namespace {

using testing_support::expect_invalid;
using testing_support::gaussian;
using Complex = std::complex<double>;

constexpr std::size_t kPeriod = 512;
constexpr double kFs = 512.0;  // line k is k Hz

// y(t) = b0·u(t) + b1·u(t−1) − a1·y(t−1) − a2·y(t−2): poles at radius √0.64 = 0.8, so one transient
// period of 512 samples leaves 0.8^512 ≈ 1e-50 of the start-up transient.
struct Filter {
  double b0 = 0.5, b1 = 0.3, a1 = -1.0, a2 = 0.64;

  Eigen::VectorXd run(const Eigen::VectorXd& u) const {
    Eigen::VectorXd y(u.size());
    for (Eigen::Index t = 0; t < u.size(); ++t) {
      double s = b0 * u[t];
      if (t >= 1) s += b1 * u[t - 1] - a1 * y[t - 1];
      if (t >= 2) s -= a2 * y[t - 2];
      y[t] = s;
    }
    return y;
  }
  // H(e^{jω}) = (b0 + b1·e^{−jω}) / (1 + a1·e^{−jω} + a2·e^{−2jω}), ω = 2πk/N
  Complex response(std::size_t k) const {
    const Complex z1 = std::polar(1.0, -2.0 * std::numbers::pi * static_cast<double>(k) / kPeriod);
    return (b0 + b1 * z1) / (1.0 + a1 * z1 + a2 * z1 * z1);
  }
};

// |U(k)|² of the first period of n samples, by the DFT sum written out.
double line_power(const Eigen::VectorXd& u, std::size_t k, std::size_t n = kPeriod) {
  Complex s = 0.0;
  for (std::size_t t = 0; t < n; ++t) {
    s += u[static_cast<Eigen::Index>(t)] *
         std::polar(1.0, -2.0 * std::numbers::pi * static_cast<double>(k * t % n) / static_cast<double>(n));
  }
  return std::norm(s);
}

struct Experiment {
  MultisineRealisations excitation;
  std::vector<Eigen::VectorXd> u, x, y;
  BlaSpec spec;
};

// M realisations of (1 transient + P) periods through the filter, then `shape` applied sample by sample,
// then white output noise of standard deviation `sigma`.
template <class Shape>
Experiment run(MultisineLines lines, std::size_t realisations, std::size_t periods, double sigma, Shape shape,
               double amplitude = 1.0) {
  MultisineSpec ms;
  ms.period = kPeriod;
  ms.periods = periods + 1;
  ms.fs = kFs;
  ms.f_min = 1.0;
  ms.f_max = 200.0;
  ms.lines = lines;
  ms.amplitude = amplitude;
  ms.seed = 11;
  Experiment e;
  e.excitation = multisine_realisations(ms, realisations);
  const Filter filter;
  for (std::size_t m = 0; m < realisations; ++m) {
    const Eigen::VectorXd& u = e.excitation.signals[m];
    Eigen::VectorXd x = filter.run(u);
    Eigen::VectorXd y = x.unaryExpr(shape);
    if (sigma > 0.0) y += gaussian(y.size(), sigma, 100 + m);
    e.u.push_back(u);
    e.x.push_back(x);
    e.y.push_back(y);
  }
  e.spec.period = kPeriod;
  e.spec.transient_periods = 1;
  e.spec.fs = kFs;
  e.spec.excited_lines = e.excitation.lines;
  e.spec.detection_f_max = ms.f_max;
  return e;
}

TEST(BestLinearApproximationTest, LinearSystemGivesItsFrequencyResponseExactly) {
  const Experiment e = run(MultisineLines::odd, 3, 2, 0.0, [](double x) { return x; });
  const BestLinearApproximation bla = best_linear_approximation(e.u, e.y, e.spec);
  ASSERT_EQ(bla.lines, e.excitation.lines);
  EXPECT_EQ(bla.realisations, 3u);
  EXPECT_EQ(bla.periods, 2u);
  const Filter filter;
  for (std::size_t i = 0; i < bla.lines.size(); ++i) {
    const Complex expected = filter.response(bla.lines[i]);
    const auto ii = static_cast<Eigen::Index>(i);
    EXPECT_LT(std::abs(bla.g[ii] - expected), 1e-9 * std::abs(expected)) << "line " << bla.lines[i];
    EXPECT_DOUBLE_EQ(bla.frequency[ii], static_cast<double>(bla.lines[i]));
    EXPECT_LT(bla.noise_variance[ii], 1e-24);
    EXPECT_LT(bla.total_variance[ii], 1e-24);
  }
}

TEST(BestLinearApproximationTest, NoiseVarianceMatchesKnownOutputNoise) {
  const double sigma = 0.05;
  const std::size_t big_m = 4, big_p = 5;
  const Experiment e = run(MultisineLines::odd, big_m, big_p, sigma, [](double x) { return x; });
  const BestLinearApproximation bla = best_linear_approximation(e.u, e.y, e.spec);
  // White noise of variance σ² has E|E(k)|² = N·σ² in every bin, so G^[m,p] = Y/U carries noise of
  // variance N·σ²/|U^[m](k)|²; averaging P periods and M realisations: Σ_m N·σ²/(|U^[m]|²·P) / M².
  double estimated = 0.0, expected = 0.0, total = 0.0;
  for (std::size_t i = 0; i < bla.lines.size(); ++i) {
    double v = 0.0;
    for (std::size_t m = 0; m < big_m; ++m) {
      v += kPeriod * sigma * sigma / (line_power(e.u[m], bla.lines[i]) * big_p);
    }
    expected += v / (big_m * big_m);
    estimated += bla.noise_variance[static_cast<Eigen::Index>(i)];
    total += bla.total_variance[static_cast<Eigen::Index>(i)];
  }
  // The pooled estimate has 2·M·(P−1) degrees of freedom per line, ~100 lines: relative standard
  // deviation ≈ 1/√(100·32) ≈ 2 % (3 % over 200 seeds); the total variance (2·(M−1) per line) 6 %.
  EXPECT_NEAR(estimated / expected, 1.0, 0.13);
  EXPECT_NEAR(total / expected, 1.0, 0.3);
  // Noise only: the detection lines hold nothing but noise.
  EXPECT_FALSE(bla.even.distortion_detected) << bla.even.level_to_noise_db;
  EXPECT_NEAR(bla.even.level_to_noise_db, 0.0, 1.5);
  EXPECT_TRUE(bla.odd.lines.empty());  // a plain odd multisine leaves no odd line empty
}

TEST(BestLinearApproximationTest, EvenNonlinearityShowsOnlyAtEvenLines) {
  const Experiment e = run(MultisineLines::random_odd, 4, 3, 0.01, [](double x) { return x + 0.3 * x * x; });
  const BestLinearApproximation bla = best_linear_approximation(e.u, e.y, e.spec);
  ASSERT_FALSE(bla.even.lines.empty());
  ASSERT_FALSE(bla.odd.lines.empty());
  EXPECT_EQ(bla.odd.lines, e.excitation.detection_lines);
  for (const std::size_t k : bla.even.lines) EXPECT_EQ(k % 2, 0u);
  EXPECT_TRUE(bla.even.distortion_detected);
  EXPECT_GT(bla.even.level_to_noise_db, 20.0);
  EXPECT_FALSE(bla.odd.distortion_detected) << bla.odd.level_to_noise_db;
  // x² maps odd lines to even lines only: the BLA at the odd lines is the filter itself plus noise, so
  // Σ|G_BLA − H|² over the lines is Σ σ²_n (spread over ~75 lines ≈ 12 %), and the realisation-to-
  // realisation variance is the noise's alone (≈ 7 %): nothing stochastic is left at the odd lines.
  const Filter filter;
  double error = 0.0, noise = 0.0, total = 0.0;
  for (std::size_t i = 0; i < bla.lines.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    error += std::norm(bla.g[ii] - filter.response(bla.lines[i]));
    noise += bla.noise_variance[ii];
    total += bla.total_variance[ii];
  }
  EXPECT_NEAR(error / noise, 1.0, 0.5);
  EXPECT_NEAR(total / noise, 1.0, 0.35);
}

TEST(BestLinearApproximationTest, OddNonlinearityShowsAtOddLinesAndScalesTheBla) {
  const double b = 0.5;
  const std::size_t big_m = 8;
  const Experiment e =
      run(MultisineLines::random_odd, big_m, 2, 0.01, [b](double x) { return x + b * x * x * x; });
  const BestLinearApproximation bla = best_linear_approximation(e.u, e.y, e.spec);
  EXPECT_TRUE(bla.odd.distortion_detected);
  EXPECT_GT(bla.odd.level_to_noise_db, 20.0);
  EXPECT_FALSE(bla.even.distortion_detected) << bla.even.level_to_noise_db;

  // Bussgang: for Gaussian x the BLA of x + b·x³ is 1 + 3b·σ_x², so G_BLA = H·(1 + 3b·σ_x²).
  double var_x = 0.0;
  for (const auto& x : e.x) var_x += x.tail(kPeriod).squaredNorm() / kPeriod / big_m;
  const double expected_gain = 1.0 + 3.0 * b * var_x;
  // A clear change, found within 15 % of itself: over 200 seeds the estimate scatters by 4 % of the
  // change around a −2 % bias (a multisine of ~75 lines is Gaussian only up to O(1/lines)).
  ASSERT_GT(expected_gain - 1.0, 0.1);
  // The gain by least squares over the lines, G_BLA ≈ ratio·H: ratio = Σ G_BLA·H* / Σ |H|².
  const Filter filter;
  Complex cross = 0.0;
  double power = 0.0, nonlinear = 0.0, noise = 0.0;
  for (std::size_t i = 0; i < bla.lines.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    const Complex h = filter.response(bla.lines[i]);
    cross += bla.g[ii] * std::conj(h);
    power += std::norm(h);
    nonlinear += bla.nonlinear_variance[ii];
    noise += bla.noise_variance[ii];
  }
  const Complex ratio = cross / power;
  EXPECT_NEAR(ratio.real(), expected_gain, 0.15 * (expected_gain - 1.0));
  EXPECT_NEAR(ratio.imag(), 0.0, 0.15 * (expected_gain - 1.0));
  // The distortion changes with the phase realisation: its variance dwarfs the noise's.
  EXPECT_GT(nonlinear, 10.0 * noise);
}

TEST(BestLinearApproximationTest, RealisationsShareLinesAndDifferInPhase) {
  MultisineSpec ms;
  ms.period = 256;
  ms.periods = 2;
  ms.fs = 256.0;
  ms.f_min = 1.0;
  ms.f_max = 60.0;
  ms.lines = MultisineLines::random_odd;
  ms.amplitude = 0.7;
  const MultisineRealisations r = multisine_realisations(ms, 3);
  const Multisine first = multisine(ms);
  ASSERT_EQ(r.signals.size(), 3u);
  EXPECT_EQ(r.lines, first.lines);
  EXPECT_EQ(r.detection_lines, first.detection_lines);
  EXPECT_EQ(r.signals[0], first.signal);
  for (std::size_t m = 1; m < 3; ++m) {
    EXPECT_NEAR(r.signals[m].cwiseAbs().maxCoeff(), 0.7, 1e-15);
    EXPECT_GT((r.signals[m] - r.signals[0]).norm(), 1.0);
    EXPECT_EQ(r.signals[m].head(256), r.signals[m].tail(256));  // exactly periodic
    for (std::size_t k = 1; k < 128; ++k) {
      const bool excited = std::find(r.lines.begin(), r.lines.end(), k) != r.lines.end();
      const double power = line_power(r.signals[m], k, 256);
      if (excited) {
        EXPECT_GT(power, 1.0) << "line " << k;
      } else {
        EXPECT_LT(power, 1e-20) << "line " << k;
      }
    }
  }
  expect_invalid([&] { multisine_realisations(ms, 0); }, "realisation");
}

TEST(BestLinearApproximationTest, RejectsInconsistentSizes) {
  const Experiment e = run(MultisineLines::odd, 2, 1, 0.0, [](double x) { return x; });
  auto spec = e.spec;
  std::vector<Eigen::VectorXd> one_y = {e.y[0]};
  expect_invalid([&] { best_linear_approximation(e.u, one_y, spec); }, "output records");
  std::vector<Eigen::VectorXd> short_y = e.y;
  short_y[1] = Eigen::VectorXd(e.y[1].head(e.y[1].size() - 1));
  expect_invalid([&] { best_linear_approximation(e.u, short_y, spec); }, "realisation 1");
  std::vector<Eigen::VectorXd> ragged_u = e.u, ragged_y = e.y;
  for (std::size_t m = 0; m < 2; ++m) {
    ragged_u[m] = Eigen::VectorXd(e.u[m].head(e.u[m].size() - 3));
    ragged_y[m] = Eigen::VectorXd(e.y[m].head(e.y[m].size() - 3));
  }
  expect_invalid([&] { best_linear_approximation(ragged_u, ragged_y, spec); }, "whole periods");
  spec.transient_periods = 2;
  expect_invalid([&] { best_linear_approximation(e.u, e.y, spec); }, "transient");
  spec = e.spec;
  spec.excited_lines.push_back(kPeriod / 2);
  expect_invalid([&] { best_linear_approximation(e.u, e.y, spec); }, "excited line 256");
  spec = e.spec;
  spec.excited_lines.push_back(2);  // an even line the input does not excite, and out of order
  expect_invalid([&] { best_linear_approximation(e.u, e.y, spec); }, "ascending");
  spec = e.spec;
  spec.excited_lines = {2};  // ascending, but no power there
  expect_invalid([&] { best_linear_approximation(e.u, e.y, spec); }, "no input power at line 2");
  expect_invalid([&] { best_linear_approximation({}, {}, e.spec); }, "no realisations");
}

}  // namespace
}  // namespace panelbass::dsp

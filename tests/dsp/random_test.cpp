// Rng: determinism, and the distributions' moments against their closed forms.
#include "dsp/random.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace panelbass::dsp {
namespace {

TEST(RngTest, SameSeedGivesSameSequence) {
  Rng a(42);
  Rng b(42);
  for (int i = 0; i < 1000; ++i) {
    ASSERT_EQ(a.uniform01(), b.uniform01());
    ASSERT_EQ(a.gaussian(), b.gaussian());
    ASSERT_EQ(a.below(17), b.below(17));
  }
}

TEST(RngTest, DifferentSeedsGiveDifferentSequences) {
  Rng a(1);
  Rng b(2);
  int equal = 0;
  for (int i = 0; i < 1000; ++i) {
    equal += a.uniform01() == b.uniform01() ? 1 : 0;
  }
  EXPECT_EQ(equal, 0);
}

TEST(RngTest, MatchesMt19937_64Reference) {
  // The standard fixes mt19937_64's 10000th output for the default seed 5489.
  Rng rng(5489);
  std::mt19937_64 engine(5489);
  engine.discard(9999);
  const std::uint64_t expected_10000th = 9981545732273789042ULL;
  EXPECT_EQ(engine(), expected_10000th);
  // uniform01 uses the top 53 bits of each engine output.
  std::mt19937_64 reference(5489);
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(rng.uniform01(), static_cast<double>(reference() >> 11) * 0x1.0p-53);
  }
}

TEST(RngTest, UniformMomentsMatchClosedForm) {
  // U[0,1): mean 1/2, variance 1/12. Standard errors for n = 200000: sqrt(1/12/n) = 6.5e-4 for the
  // mean; sqrt((1/80 − 1/144)/n) = 1.7e-4 for the variance. Bounds are 5 standard errors.
  Rng rng(7);
  const int n = 200000;
  double sum = 0.0;
  double sum_sq = 0.0;
  for (int i = 0; i < n; ++i) {
    const double u = rng.uniform01();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum += u;
    sum_sq += u * u;
  }
  const double mean = sum / n;
  const double variance = sum_sq / n - mean * mean;
  EXPECT_NEAR(mean, 0.5, 5 * 6.5e-4);
  EXPECT_NEAR(variance, 1.0 / 12.0, 5 * 1.7e-4);
}

TEST(RngTest, UniformRangeStaysInside) {
  Rng rng(3);
  for (int i = 0; i < 10000; ++i) {
    const double v = rng.uniform(-2.5, 4.0);
    ASSERT_GE(v, -2.5);
    ASSERT_LT(v, 4.0);
  }
}

TEST(RngTest, GaussianMomentsMatchStandardNormal) {
  // N(0,1): standard errors for n = 200000 are 1/sqrt(n) = 2.2e-3 (mean), sqrt(2/n) = 3.2e-3
  // (variance), sqrt(p(1−p)/n) = 1.0e-3 for P(|x| < 1) = erf(1/√2) = 0.682689.
  Rng rng(11);
  const int n = 200000;
  double sum = 0.0;
  double sum_sq = 0.0;
  int inside_one_sigma = 0;
  for (int i = 0; i < n; ++i) {
    const double g = rng.gaussian();
    sum += g;
    sum_sq += g * g;
    inside_one_sigma += std::abs(g) < 1.0 ? 1 : 0;
  }
  const double mean = sum / n;
  EXPECT_NEAR(mean, 0.0, 5 * 2.2e-3);
  EXPECT_NEAR(sum_sq / n - mean * mean, 1.0, 5 * 3.2e-3);
  EXPECT_NEAR(static_cast<double>(inside_one_sigma) / n, std::erf(1.0 / std::sqrt(2.0)),
              5 * 1.0e-3);
}

TEST(RngTest, GaussianPairsAreUncorrelated) {
  // The polar method returns two values per accepted point; they must be independent.
  // Standard error of the lag-1 correlation is 1/sqrt(n) = 3.2e-3 for n = 100000 pairs.
  Rng rng(5);
  const int n = 100000;
  double sum = 0.0;
  for (int i = 0; i < n; ++i) {
    const double first = rng.gaussian();
    const double second = rng.gaussian();
    sum += first * second;
  }
  EXPECT_NEAR(sum / n, 0.0, 5 * 3.2e-3);
}

TEST(RngTest, BelowIsUniformByChiSquare) {
  // 10 cells, 100000 draws: chi-square with 9 degrees of freedom, P(χ² > 33.7) = 1e-4.
  Rng rng(13);
  const int cells = 10;
  const int n = 100000;
  std::vector<int> counts(cells, 0);
  for (int i = 0; i < n; ++i) {
    const std::uint64_t v = rng.below(cells);
    ASSERT_LT(v, static_cast<std::uint64_t>(cells));
    ++counts[v];
  }
  const double expected = static_cast<double>(n) / cells;
  double chi_square = 0.0;
  for (const int c : counts) {
    EXPECT_GT(c, 0);
    chi_square += (c - expected) * (c - expected) / expected;
  }
  EXPECT_LT(chi_square, 33.7);
}

TEST(RngTest, BelowHandlesEdgeSizes) {
  Rng rng(17);
  for (int i = 0; i < 100; ++i) {
    EXPECT_EQ(rng.below(1), 0u);
  }
  // Just above 2^63 about half of the raw draws are rejected; values must stay below n and both
  // halves of the range must appear.
  const std::uint64_t n = (std::uint64_t{1} << 63) + 1;
  int high = 0;
  for (int i = 0; i < 1000; ++i) {
    const std::uint64_t v = rng.below(n);
    ASSERT_LT(v, n);
    high += v >= n / 2 ? 1 : 0;
  }
  EXPECT_GT(high, 400);
  EXPECT_LT(high, 600);
  EXPECT_THROW(rng.below(0), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::dsp

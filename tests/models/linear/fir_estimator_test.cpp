// estimate_fir against exact recovery, the least-squares noise theory, and a brute-force QR solution
// of the full regressor matrix; simulate_fir against a plain convolution; the argument checks.
#include "models/linear/fir_estimator.h"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "dsp/excitation.h"
#include "dsp/random.h"
#include "tests/support/linear_systems.h"

namespace panelbass::models {
namespace {

using testing_support::gaussian;

/// y(k) = Σ_{j=0}^{min(n−1,k)} b_j·u(k−j), written as the textbook double loop.
Eigen::VectorXd convolve(const Eigen::VectorXd& b, const Eigen::VectorXd& u) {
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    double s = 0.0;
    for (Eigen::Index j = 0; j < b.size(); ++j) {
      if (k - j >= 0) s += b[j] * u[k - j];
    }
    y[k] = s;
  }
  return y;
}

/// The least-squares solution from the full (N−n+1)×n regressor matrix, row k = [u(k) … u(k−n+1)]
/// for k = n−1..N−1, solved by Householder QR with column pivoting.
Eigen::VectorXd brute_force_ls(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index n) {
  const Eigen::Index rows = u.size() - n + 1;
  Eigen::MatrixXd phi(rows, n);
  Eigen::VectorXd target(rows);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const Eigen::Index k = r + n - 1;
    for (Eigen::Index j = 0; j < n; ++j) phi(r, j) = u[k - j];
    target[r] = y[k];
  }
  return phi.colPivHouseholderQr().solve(target);
}

TEST(FirEstimatorTest, RecoversKnownFirExactlyFromNoiseFreeData) {
  Eigen::VectorXd b(8);
  b << 0.0, 0.5, -0.3, 0.8, 0.1, -0.05, 0.02, -0.4;
  const Eigen::VectorXd u = dsp::uniform_noise(2000, 1.0, 101);
  const Eigen::VectorXd y = convolve(b, u);
  const Eigen::VectorXd est = estimate_fir(u, y, 8);
  ASSERT_EQ(est.size(), 8);
  for (Eigen::Index j = 0; j < 8; ++j) EXPECT_NEAR(est[j], b[j], 1e-10) << "tap " << j;
}

TEST(FirEstimatorTest, RecoversKnownFirWithMoreTapsThanTheSystem) {
  // A 5-tap system fitted with 12 taps: the extra taps come out zero.
  Eigen::VectorXd b = Eigen::VectorXd::Zero(12);
  b.head(5) << 1.0, -0.7, 0.2, 0.0, 0.3;
  const Eigen::VectorXd u = gaussian(500, 1.0, 102);
  const Eigen::VectorXd est = estimate_fir(u, convolve(b.head(5), u), 12);
  for (Eigen::Index j = 0; j < 12; ++j) EXPECT_NEAR(est[j], b[j], 1e-10) << "tap " << j;
}

TEST(FirEstimatorTest, RecoversExactlyAtTheMinimumRecordLength) {
  Eigen::VectorXd b(4);
  b << 0.9, -0.2, 0.4, 0.1;
  const Eigen::VectorXd u = dsp::uniform_noise(8, 1.0, 103);  // N = 2n exactly
  const Eigen::VectorXd est = estimate_fir(u, convolve(b, u), 4);
  for (Eigen::Index j = 0; j < 4; ++j) EXPECT_NEAR(est[j], b[j], 1e-9) << "tap " << j;
}

TEST(FirEstimatorTest, NoisyEstimateErrorMatchesLeastSquaresTheory) {
  // y = b*u + e, e white with σ_e: Cov(b̂) = σ_e²(ΦᵀΦ)⁻¹ ≈ σ_e²/(N'σ_u²)·I for white u, N' = N−n+1
  // equations. u uniform in [−1, 1] has σ_u = 1/√3. Over 20 records × 10 taps = 200 errors the RMS is
  // within ±5 % (1 σ) of the theory; we accept a factor 1.25 either way (5 σ).
  const Eigen::Index N = 4000, n = 10;
  const double sigma_e = 0.1, sigma_u = 1.0 / std::sqrt(3.0);
  Eigen::VectorXd b(n);
  b << 0.2, 1.0, 0.6, -0.3, -0.5, -0.1, 0.15, 0.1, 0.0, -0.05;
  const double theory = sigma_e / (sigma_u * std::sqrt(static_cast<double>(N - n + 1)));
  double sum_sq = 0.0, sum = 0.0;
  const int records = 20;
  for (int r = 0; r < records; ++r) {
    const Eigen::VectorXd u = dsp::uniform_noise(N, 1.0, 200 + r);
    const Eigen::VectorXd y = convolve(b, u) + gaussian(N, sigma_e, 300 + r);
    const Eigen::VectorXd err = estimate_fir(u, y, n) - b;
    sum_sq += err.squaredNorm();
    sum += err.sum();
  }
  const double count = static_cast<double>(records * n);
  const double rms = std::sqrt(sum_sq / count);
  EXPECT_GT(rms, theory / 1.25) << "theory " << theory;
  EXPECT_LT(rms, theory * 1.25) << "theory " << theory;
  // Unbiased: the mean error is within 4 standard errors of zero.
  EXPECT_LT(std::abs(sum / count), 4.0 * theory / std::sqrt(count));
}

TEST(FirEstimatorTest, EqualsBruteForceQrLeastSquares) {
  // y unrelated to any FIR (so the residual is large and the fit is a genuine compromise), and an
  // input with a non-zero mean and colour so the normal equations are not near-diagonal.
  for (const auto& [N, n] : {std::pair<Eigen::Index, Eigen::Index>{60, 7}, {40, 1}, {14, 7}, {101, 13}}) {
    Eigen::VectorXd u = dsp::uniform_noise(static_cast<std::size_t>(N), 1.0, 400 + N);
    for (Eigen::Index k = N - 1; k >= 1; --k) u[k] += 0.6 * u[k - 1] + 0.3;
    const Eigen::VectorXd y = gaussian(N, 1.0, 500 + N);
    const Eigen::VectorXd est = estimate_fir(u, y, n);
    const Eigen::VectorXd ref = brute_force_ls(u, y, n);
    ASSERT_EQ(est.size(), n);
    for (Eigen::Index j = 0; j < n; ++j) EXPECT_NEAR(est[j], ref[j], 1e-9) << "N " << N << " n " << n << " tap " << j;
  }
}

TEST(FirEstimatorTest, SimulateFirEqualsPlainConvolution) {
  const Eigen::VectorXd u = dsp::uniform_noise(300, 1.0, 600);
  const Eigen::VectorXd b = gaussian(17, 0.5, 601);
  const Eigen::VectorXd y = simulate_fir(b, u);
  const Eigen::VectorXd ref = convolve(b, u);
  ASSERT_EQ(y.size(), 300);
  for (Eigen::Index k = 0; k < 300; ++k) EXPECT_NEAR(y[k], ref[k], 1e-12) << k;
}

TEST(FirEstimatorTest, SimulateFirWithFilterLongerThanInput) {
  const Eigen::VectorXd u = dsp::uniform_noise(5, 1.0, 602);
  const Eigen::VectorXd b = gaussian(9, 1.0, 603);
  const Eigen::VectorXd y = simulate_fir(b, u);
  const Eigen::VectorXd ref = convolve(b, u);
  ASSERT_EQ(y.size(), 5);
  for (Eigen::Index k = 0; k < 5; ++k) EXPECT_NEAR(y[k], ref[k], 1e-12) << k;
}

TEST(FirEstimatorTest, SimulateFirOfUnitImpulseIsTheCoefficients) {
  Eigen::VectorXd b(4);
  b << 0.5, -1.0, 0.25, 2.0;
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(10);
  delta[0] = 1.0;
  const Eigen::VectorXd y = simulate_fir(b, delta);
  for (Eigen::Index k = 0; k < 10; ++k) EXPECT_EQ(y[k], k < 4 ? b[k] : 0.0) << k;
}

TEST(FirEstimatorTest, TooFewSamplesThrowsNamingCounts) {
  const Eigen::VectorXd u = dsp::uniform_noise(19, 1.0, 700);
  try {
    estimate_fir(u, u, 10);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("19"), std::string::npos) << msg;  // samples given
    EXPECT_NE(msg.find("10"), std::string::npos) << msg;  // taps
    EXPECT_NE(msg.find("20"), std::string::npos) << msg;  // samples needed
  }
  EXPECT_NO_THROW(estimate_fir(dsp::uniform_noise(20, 1.0, 701), dsp::uniform_noise(20, 1.0, 702), 10));
}

TEST(FirEstimatorTest, ZeroInputThrows) {
  EXPECT_THROW(estimate_fir(Eigen::VectorXd::Zero(100), dsp::uniform_noise(100, 1.0, 703), 5), std::invalid_argument);
}

TEST(FirEstimatorTest, MismatchedLengthsThrow) {
  EXPECT_THROW(estimate_fir(dsp::uniform_noise(100, 1.0, 704), dsp::uniform_noise(99, 1.0, 705), 5),
               std::invalid_argument);
}

TEST(FirEstimatorTest, NonPositiveTapsThrow) {
  const Eigen::VectorXd u = dsp::uniform_noise(100, 1.0, 706);
  EXPECT_THROW(estimate_fir(u, u, 0), std::invalid_argument);
  EXPECT_THROW(estimate_fir(u, u, -3), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

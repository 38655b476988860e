// estimate_arx against exact recovery of a noise-free ARX system, a plain normal-equation solution
// written out in the test, a long record, and every argument check with its message.
#include "models/linear/arx_estimator.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <cmath>
#include <limits>
#include <string>

#include "dsp/excitation.h"
#include "dsp/random.h"
#include "models/linear/estimation_error.h"
#include "tests/support/expect_error.h"
#include "tests/support/linear_systems.h"

namespace panelbass::models {
namespace {

using testing_support::arx_output;
using testing_support::gaussian;

/// θ from the normal equations (ΦᵀΦ)θ = Φᵀy, Φ filled element by element from the definition
/// φ(k) = [−y(k−1)…−y(k−na), u(k−nk)…u(k−nk−nb+1)], k = max(na, nk+nb−1) … N−1.
Eigen::VectorXd normal_equation_solution(const Eigen::VectorXd& u, const Eigen::VectorXd& y, int na, int nb, int nk) {
  const int first = std::max(na, nk + nb - 1);
  const Eigen::Index rows = u.size() - first, P = na + nb;
  Eigen::MatrixXd phi(rows, P);
  Eigen::VectorXd target(rows);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const Eigen::Index k = r + first;
    for (int i = 1; i <= na; ++i) phi(r, i - 1) = -y[k - i];
    for (int j = 0; j < nb; ++j) phi(r, na + j) = u[k - nk - j];
    target[r] = y[k];
  }
  const Eigen::MatrixXd normal = phi.transpose() * phi;
  return normal.ldlt().solve(phi.transpose() * target);
}

std::string error_of(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const ModelOrders& o) {
  return testing_support::message_of<EstimationError>([&] { estimate_arx(u, y, o); }, "(no error)");
}

TEST(ArxEstimatorTest, RecoversExactArxSystemFromNoiseFreeData) {
  TransferFunction truth;
  truth.a = Eigen::Vector2d(-1.5, 0.7);  // poles 0.75 ± 0.37j
  truth.b = Eigen::Vector3d(0.5, -0.2, 0.1);
  truth.nk = 2;
  const Eigen::VectorXd u = dsp::uniform_noise(2000, 1.0, 11);
  const Eigen::VectorXd y = arx_output(truth, u, {});
  const TransferFunction est = estimate_arx(u, y, {2, 3, 2});
  ASSERT_EQ(est.na(), 2);
  ASSERT_EQ(est.nb(), 3);
  EXPECT_EQ(est.nk, 2);
  for (int i = 0; i < 2; ++i) EXPECT_NEAR(est.a[i], truth.a[i], 1e-10) << "a_" << i + 1;
  for (int j = 0; j < 3; ++j) EXPECT_NEAR(est.b[j], truth.b[j], 1e-10) << "b_" << j;
}

TEST(ArxEstimatorTest, EqualsPlainNormalEquationSolutionOnSmallNoisyData) {
  // Small, well-conditioned problems, where the normal equations lose nothing that matters at 1e-9.
  const Eigen::VectorXd u = dsp::uniform_noise(80, 1.0, 21);
  TransferFunction sys;
  sys.a = Eigen::Vector2d(-0.9, 0.3);
  sys.b = Eigen::Vector2d(1.0, 0.4);
  sys.nk = 1;
  const Eigen::VectorXd y = arx_output(sys, u, gaussian(80, 0.3, 22));
  for (const ModelOrders o : {ModelOrders{2, 2, 1}, ModelOrders{3, 1, 0}, ModelOrders{0, 4, 2}, ModelOrders{1, 3, 3}}) {
    const TransferFunction est = estimate_arx(u, y, o);
    const Eigen::VectorXd ref = normal_equation_solution(u, y, o.na, o.nb, o.nk);
    Eigen::VectorXd theta(o.na + o.nb);
    theta << est.a, est.b;
    EXPECT_LT((theta - ref).cwiseAbs().maxCoeff(), 1e-9) << "na=" << o.na << " nb=" << o.nb << " nk=" << o.nk;
  }
}

TEST(ArxEstimatorTest, UsesExactlyTheSamplesWhoseRegressorsLieInsideTheRecord) {
  // An output sample that no row touches (before k0 − na) can be anything without changing the result;
  // the first one a row touches changes it.
  const Eigen::VectorXd u = dsp::uniform_noise(40, 1.0, 31);
  Eigen::VectorXd y = gaussian(40, 1.0, 32);
  const ModelOrders o{1, 2, 3};  // k0 = max(1, 3 + 2 − 1) = 4; row k uses y(k−1), so y(0..2) are unused
  const TransferFunction base = estimate_arx(u, y, o);
  Eigen::VectorXd y_early = y;
  y_early.head(3).setConstant(100.0);
  const TransferFunction same = estimate_arx(u, y_early, o);
  EXPECT_LT((same.b - base.b).norm() + (same.a - base.a).norm(), 1e-12);
  Eigen::VectorXd y_used = y;
  y_used[3] += 1.0;  // y(3) is −y(k−1) at k = 4
  const TransferFunction changed = estimate_arx(u, y_used, o);
  EXPECT_GT((changed.a - base.a).norm(), 1e-6);
}

TEST(ArxEstimatorTest, LongRecordHighOrderEqualsFullQrAndContainsTheTruth) {
  // N = 1e5 and 40 parameters (the size of Zhu's high-order step). With white equation noise the
  // ARX(20,20) has the true polynomials padded with zeros as its unique optimum; the y-lag coefficients
  // spread by ~1e-2 here (the lagged outputs are strongly correlated), the u-lag ones by ~1e-3.
  TransferFunction truth;
  truth.a = Eigen::Vector2d(-1.6, 0.8);
  truth.b = Eigen::Vector2d(0.3, 0.2);
  truth.nk = 1;
  const Eigen::Index N = 100000;
  const Eigen::VectorXd u = dsp::uniform_noise(N, 1.0, 41);
  const Eigen::VectorXd y = arx_output(truth, u, gaussian(N, 0.1, 42));
  const TransferFunction est = estimate_arx(u, y, {20, 20, 1});
  EXPECT_NEAR(est.a[0], -1.6, 1e-2);
  EXPECT_NEAR(est.a[1], 0.8, 1e-2);
  EXPECT_NEAR(est.b[0], 0.3, 1e-2);
  EXPECT_NEAR(est.b[1], 0.2, 1e-2);
  EXPECT_LT(est.a.tail(18).cwiseAbs().maxCoeff(), 5e-2);
  EXPECT_LT(est.b.tail(18).cwiseAbs().maxCoeff(), 1e-2);

  // The same problem solved the obvious way: the whole regressor matrix, pivoted Householder QR.
  Eigen::MatrixXd phi(N - 20, 40);
  for (Eigen::Index r = 0; r < N - 20; ++r) {
    const Eigen::Index k = r + 20;
    for (int i = 1; i <= 20; ++i) phi(r, i - 1) = -y[k - i];
    for (int j = 0; j < 20; ++j) phi(r, 20 + j) = u[k - 1 - j];
  }
  const Eigen::VectorXd ref = phi.colPivHouseholderQr().solve(Eigen::VectorXd(y.tail(N - 20)));
  Eigen::VectorXd theta(40);
  theta << est.a, est.b;
  EXPECT_LT((theta - ref).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(ArxEstimatorTest, ScaledOutputIsNotMistakenForRankDeficiency) {
  // y a million times smaller than u: the columns differ in size, not in independence.
  TransferFunction truth;
  truth.a = Eigen::Vector2d(-1.5, 0.7);
  truth.b = Eigen::Vector2d(1e-6, 0.5e-6);
  const Eigen::VectorXd u = dsp::uniform_noise(500, 1.0, 51);
  const Eigen::VectorXd y = arx_output(truth, u, {});
  const TransferFunction est = estimate_arx(u, y, {2, 2, 0});
  EXPECT_NEAR(est.a[0], -1.5, 1e-8);
  EXPECT_NEAR(est.b[1], 0.5e-6, 1e-13);
}

TEST(ArxEstimatorTest, TooFewSamplesSaysHowManyAreUsable) {
  // k0 = max(8, 2 + 8 − 1) = 9, so N = 21 leaves 12 rows for 16 parameters.
  const Eigen::VectorXd u = dsp::uniform_noise(21, 1.0, 61), y = gaussian(21, 1.0, 62);
  EXPECT_EQ(error_of(u, y, {8, 8, 2}), "ARX(na=8, nb=8, nk=2): 12 usable samples are too few for 16 parameters");
  const Eigen::VectorXd u5 = dsp::uniform_noise(5, 1.0, 63), y5 = gaussian(5, 1.0, 64);
  EXPECT_EQ(error_of(u5, y5, {2, 8, 0}), "ARX(na=2, nb=8, nk=0): 0 usable samples are too few for 10 parameters");
}

TEST(ArxEstimatorTest, RejectsNonFiniteDataNamingTheSample) {
  const Eigen::VectorXd u = dsp::uniform_noise(100, 1.0, 71), y = gaussian(100, 1.0, 72);
  Eigen::VectorXd bad_u = u;
  bad_u[17] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(error_of(bad_u, y, {2, 2, 1}), "ARX(na=2, nb=2, nk=1): the input has a non-finite value at sample 17");
  Eigen::VectorXd bad_y = y;
  bad_y[42] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(error_of(u, bad_y, {2, 2, 1}), "ARX(na=2, nb=2, nk=1): the output has a non-finite value at sample 42");
}

TEST(ArxEstimatorTest, RejectsConstantInput) {
  const Eigen::VectorXd y = gaussian(100, 1.0, 81);
  EXPECT_EQ(error_of(Eigen::VectorXd::Constant(100, 0.5), y, {2, 2, 0}), "ARX(na=2, nb=2, nk=0): the input is constant");
  EXPECT_EQ(error_of(Eigen::VectorXd::Zero(100), y, {2, 2, 0}), "ARX(na=2, nb=2, nk=0): the input is constant");
  EXPECT_EQ(error_of(Eigen::VectorXd(0), Eigen::VectorXd(0), {2, 2, 0}), "ARX(na=2, nb=2, nk=0): the input is constant");
}

TEST(ArxEstimatorTest, RejectsUnequalLengthsAndBadOrders) {
  const Eigen::VectorXd u = dsp::uniform_noise(100, 1.0, 91), y = gaussian(99, 1.0, 92);
  EXPECT_EQ(error_of(u, y, {2, 2, 0}), "ARX(na=2, nb=2, nk=0): the input has 100 samples but the output has 99");
  const Eigen::VectorXd y100 = gaussian(100, 1.0, 93);
  EXPECT_EQ(error_of(u, y100, {-1, 2, 0}), "ARX(na=-1, nb=2, nk=0): orders must not be negative");
  EXPECT_EQ(error_of(u, y100, {2, -2, 0}), "ARX(na=2, nb=-2, nk=0): orders must not be negative");
  EXPECT_EQ(error_of(u, y100, {2, 2, -1}), "ARX(na=2, nb=2, nk=-1): orders must not be negative");
  EXPECT_EQ(error_of(u, y100, {2, 0, 0}), "ARX(na=2, nb=0, nk=0): nb must be at least 1 (the model needs an input)");
}

TEST(ArxEstimatorTest, RankDeficientProblemSaysTheInputDoesNotExcite) {
  // A sine excites two parameters: three FIR taps on it are not identifiable.
  const Eigen::VectorXd u = dsp::sine(500, 1000.0, 50.0, 1.0);
  const Eigen::VectorXd y = gaussian(500, 1.0, 101);
  EXPECT_EQ(error_of(u, y, {0, 3, 0}), "ARX(na=0, nb=3, nk=0): the input does not excite 3 parameters (rank 2)");
  // Noise-free data of a second-order system satisfy every higher-order ARX equation too.
  TransferFunction sys;
  sys.a = Eigen::Vector2d(-1.5, 0.7);
  sys.b = Eigen::Vector2d(0.5, 0.2);
  const Eigen::VectorXd u2 = dsp::uniform_noise(500, 1.0, 102);
  EXPECT_EQ(error_of(u2, arx_output(sys, u2, {}), {3, 3, 0}),
            "ARX(na=3, nb=3, nk=0): the input does not excite 6 parameters (rank 5)");
  // An output that is zero leaves the −y regressors empty.
  EXPECT_EQ(error_of(u2, Eigen::VectorXd::Zero(500), {1, 1, 0}),
            "ARX(na=1, nb=1, nk=0): the data do not excite 2 parameters (the regressor -y(k-1) is zero on every "
            "usable sample)");
}

}  // namespace
}  // namespace panelbass::models

// least_squares against independent answers: an exact line through noise-free points (its coefficients), the
// normal equations' solution of a well-conditioned random problem over many row blocks (solved by LDLᵀ, not by
// QR), the residual's orthogonality to every regressor, a duplicated column (rank P − 1, the same fit as
// without it), a wide problem (fewer rows than columns), and a named error for mismatched sizes.
#include "models/optimization/least_squares.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>
#include <stdexcept>

namespace panelbass::models {
namespace {

Eigen::MatrixXd random_matrix(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd m(rows, cols);
  for (Eigen::Index j = 0; j < cols; ++j)
    for (Eigen::Index i = 0; i < rows; ++i) m(i, j) = n(rng);
  return m;
}

TEST(LeastSquares, AnExactLineIsRecovered) {
  const Eigen::Index n = 7;
  Eigen::MatrixXd phi(n, 2);
  Eigen::VectorXd y(n);
  for (Eigen::Index k = 0; k < n; ++k) phi(k, 0) = 1.0, phi(k, 1) = static_cast<double>(k), y[k] = 2.0 + 3.0 * k;
  const LeastSquares fit = least_squares(phi, y);
  EXPECT_EQ(fit.rank, 2);
  EXPECT_NEAR(fit.theta[0], 2.0, 1e-12);
  EXPECT_NEAR(fit.theta[1], 3.0, 1e-12);
}

TEST(LeastSquares, EqualsTheNormalEquationsOverManyRowBlocks) {
  // 5000 rows: several of the blocks the rows are reduced in, and a last block shorter than the others.
  const Eigen::MatrixXd phi = random_matrix(5000, 12, 1);
  const Eigen::VectorXd y = random_matrix(5000, 1, 2);
  const Eigen::VectorXd expected = (phi.transpose() * phi).ldlt().solve(phi.transpose() * y);
  const LeastSquares fit = least_squares(phi, y);
  EXPECT_EQ(fit.rank, 12);
  EXPECT_LT((fit.theta - expected).cwiseAbs().maxCoeff(), 1e-12);
  // The residual is orthogonal to every regressor.
  EXPECT_LT((phi.transpose() * (y - phi * fit.theta)).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(LeastSquares, ADuplicatedColumnLowersTheRankAndKeepsTheFit) {
  const Eigen::MatrixXd base = random_matrix(3000, 4, 3);
  const Eigen::VectorXd y = random_matrix(3000, 1, 4);
  Eigen::MatrixXd phi(3000, 5);
  phi << base, base.col(1);
  const LeastSquares fit = least_squares(phi, y);
  EXPECT_EQ(fit.rank, 4);
  ASSERT_TRUE(fit.theta.allFinite());
  const Eigen::VectorXd alone = (base.transpose() * base).ldlt().solve(base.transpose() * y);
  EXPECT_LT((phi * fit.theta - base * alone).cwiseAbs().maxCoeff(), 1e-10);
  // The basic solution: of two equal columns one carries the coefficient, the other is zero.
  EXPECT_TRUE(fit.theta[1] == 0.0 || fit.theta[4] == 0.0) << fit.theta.transpose();
}

TEST(LeastSquares, AWideProblemIsSolvedExactlyAtItsRank) {
  const Eigen::MatrixXd phi = random_matrix(3, 5, 5);
  const Eigen::VectorXd y = random_matrix(3, 1, 6);
  const LeastSquares fit = least_squares(phi, y);
  EXPECT_EQ(fit.rank, 3);
  EXPECT_LT((phi * fit.theta - y).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(LeastSquares, MismatchedSizesAreNamed) {
  try {
    least_squares(Eigen::MatrixXd::Ones(4, 2), Eigen::VectorXd::Ones(3));
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("4 rows of regressors against 3 samples"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace panelbass::models

// Kung's realisation made MIMO: from the exact Markov parameters of a known 2-input 3-output system, the
// realisation reproduces them (computed here by C·A^(k−1)·B, tests/support/mimo_systems.h), and the block
// Hankel matrix has exactly the system's order of non-zero singular values. The SISO cases stay in
// backx_estimator_test.cpp, unchanged.
#include "models/linear/hankel_reduction.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "tests/support/mimo_systems.h"

namespace panelbass::models {
namespace {

using testing_support::mimo_system;
using testing_support::true_markov;

TEST(KungRealizationTest, MimoMarkovParametersOfAKnownSystemAreReproduced) {
  const MimoStateSpace truth = mimo_system({{0.9, 0.3}, {0.7, 1.4}}, 2, 3, 11);  // order 4, m = 2, p = 3
  const std::vector<Eigen::MatrixXd> h = true_markov(truth, 41);
  Eigen::VectorXd sigma;
  const MimoStateSpace ss = kung_realization(h, 4, &sigma);
  ASSERT_EQ(ss.order(), 4);
  ASSERT_EQ(ss.B.cols(), 2);
  ASSERT_EQ(ss.C.rows(), 3);
  EXPECT_LT(sigma[4], 1e-10 * sigma[0]) << "a rank-4 block Hankel matrix";
  EXPECT_GT(sigma[3], 1e-4 * sigma[0]);
  // C·A^(k−1)·B of the realisation against the given h_k, k = 0..80 (beyond the 41 it was given too).
  const std::vector<Eigen::MatrixXd> longer = true_markov(truth, 81);
  const std::vector<Eigen::MatrixXd> got = true_markov(ss, 81);
  double scale = 0.0;
  for (const auto& m : longer) scale = std::max(scale, m.cwiseAbs().maxCoeff());
  for (std::size_t k = 0; k < longer.size(); ++k) {
    EXPECT_LT((got[k] - longer[k]).cwiseAbs().maxCoeff(), 1e-9 * scale) << "k = " << k;
  }
}

TEST(KungRealizationTest, RefusesTooFewOrUnequalMarkovParameters) {
  const MimoStateSpace truth = mimo_system({{0.9, 0.3}}, 2, 3, 3);
  std::vector<Eigen::MatrixXd> h = true_markov(truth, 9);  // 8 after D: too few for order 4
  EXPECT_THROW(kung_realization(h, 4), std::invalid_argument);
  h = true_markov(truth, 20);
  h[5] = Eigen::MatrixXd::Zero(2, 2);
  EXPECT_THROW(kung_realization(h, 2), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

// The MIMO impulse response from periodic data: noise-free steady-state records of a known 2-input
// 3-output system (simulated by hand, tests/support/mimo_systems.h) give back its Markov parameters
// C·A^(k−1)·B exactly once the response has died out within the taps.
#include "models/linear/periodic_impulse_response.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "tests/support/mimo_systems.h"

namespace panelbass::models {
namespace {

using namespace testing_support;

TEST(PeriodicImpulseResponseTest, NoiseFreeSteadyStateGivesTheTrueMarkovParameters) {
  const MimoStateSpace truth = mimo_system({{0.7, 0.5}, {0.6, 2.0}}, 2, 3, 5);  // 0.7^120 ≈ 3e-19
  std::vector<Eigen::MatrixXd> u, y;
  for (std::uint64_t r = 0; r < 2; ++r) {
    u.push_back(gaussian_matrix(512, 2, 100 + r));
    y.push_back(steady_state_output(truth, u.back(), 3));
  }
  const std::vector<Eigen::MatrixXd> g = estimate_periodic_impulse_response(u, y, 120);
  const std::vector<Eigen::MatrixXd> h = true_markov(truth, 120);
  ASSERT_EQ(g.size(), h.size());
  for (std::size_t k = 0; k < h.size(); ++k) {
    ASSERT_EQ(g[k].rows(), 3);
    ASSERT_EQ(g[k].cols(), 2);
    EXPECT_LT((g[k] - h[k]).cwiseAbs().maxCoeff(), 1e-9) << "k = " << k;
  }
}

TEST(PeriodicImpulseResponseTest, RefusesBadShapesAndTaps) {
  std::vector<Eigen::MatrixXd> u{gaussian_matrix(64, 2, 1)}, y{gaussian_matrix(64, 3, 2)};
  EXPECT_THROW(estimate_periodic_impulse_response(u, y, 0), std::invalid_argument);
  EXPECT_THROW(estimate_periodic_impulse_response(u, y, 65), std::invalid_argument);
  std::vector<Eigen::MatrixXd> short_y{gaussian_matrix(63, 3, 2)};
  EXPECT_THROW(estimate_periodic_impulse_response(u, short_y, 4), std::invalid_argument);
  // One realisation of 64 samples cannot determine 2·40 taps per output without a ridge.
  std::vector<Eigen::MatrixXd> sine{Eigen::MatrixXd::Zero(64, 2)};
  sine[0].col(0).setOnes();
  EXPECT_THROW(estimate_periodic_impulse_response(sine, y, 40), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

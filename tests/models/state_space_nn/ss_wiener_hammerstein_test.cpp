// The Wiener–Hammerstein start of the neural state-space model against a simulated Wiener–Hammerstein
// system whose blocks are known: the split found is the true one (the resonant pair in front, the back
// filter's pole and zero behind), the start written as a state-space model is far better than the linear
// model it came from, it simulates exactly as the block model written out by hand, and the joint
// Levenberg–Marquardt refinement lowers its J well below the search's.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "dsp/excitation.h"
#include "models/linear/state_space.h"
#include "models/state_space_nn/ss_wiener_hammerstein.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

// The best linear approximation of wh_test_system stood in for by its small-signal linearisation (g'(0) = 1):
// 0.2·q⁻¹·(1 − 0.9q⁻¹) / ((1 − 1.6q⁻¹ + 0.8q⁻²)(1 − 0.5q⁻¹)).
LinearModel wh_test_bla() {
  LinearModel bla;
  bla.fs = 1000.0;
  bla.tf.a = Eigen::Vector3d(-2.1, 1.6, -0.4);
  bla.tf.b = Eigen::Vector2d(0.2, -0.18);
  bla.tf.nk = 1;
  return bla;
}

// Front: v(k) = 1.6·v(k−1) − 0.8·v(k−2) + 0.2·u(k−1) (poles 0.8 ± 0.4j, DC gain 1); an asymmetric
// saturation w = tanh(v) + 0.1·v²; back: y(k) = 0.5·y(k−1) + w(k) − 0.9·w(k−1).
Eigen::VectorXd wh_test_system(const Eigen::VectorXd& u) {
  Eigen::VectorXd y(u.size());
  double v1 = 0.0, v2 = 0.0, u1 = 0.0, w1 = 0.0, y1 = 0.0;
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    const double v = 1.6 * v1 - 0.8 * v2 + 0.2 * u1;
    const double w = std::tanh(v) + 0.1 * v * v;
    y(k) = 0.5 * y1 + w - 0.9 * w1;
    v2 = v1;
    v1 = v;
    u1 = u(k);
    w1 = w;
    y1 = y(k);
  }
  return y;
}

TEST(SsWienerHammerstein, FindsTheTrueSplitAndStartsFarBelowTheLinearModel) {
  const Eigen::VectorXd u = dsp::uniform_noise(6000, 2.0, 21), y = wh_test_system(u);
  const Eigen::VectorXd ue = u.head(4000), ye = y.head(4000), uv = u.tail(2000), yv = y.tail(2000);
  const LinearModel bla = wh_test_bla();
  const SsWienerHammerstein wh = ss_wiener_hammerstein_start(bla, {3, 12, 8, 0}, ue, ye, uv, yv, 0, 1);
  EXPECT_EQ(wh.front_poles, 2);
  EXPECT_EQ(wh.front_zeros, 0);
  EXPECT_EQ(wh.front_states, 2);
  EXPECT_EQ(wh.model.structure.states, 3);
  EXPECT_GT(wh.splits, 1);
  const Eigen::Index init = 20;
  const double j_linear = j_percent(bla.simulate(uv, yv, init), yv, init);
  const double j_start = j_percent(wh.model.simulate(uv, yv, init), yv, init);
  EXPECT_LT(j_start, 0.02 * j_linear) << "linear " << j_linear;
  EXPECT_LT(wh.j_pct, 0.02 * wh.linear_j_pct);
}

TEST(SsWienerHammerstein, TheStateSpaceFormSimulatesAsTheBlocksWrittenOut) {
  const Eigen::VectorXd u = dsp::uniform_noise(3000, 2.0, 22), y = wh_test_system(u);
  const LinearModel bla = wh_test_bla();
  const SsWienerHammerstein wh = ss_wiener_hammerstein_start(bla, {3, 6, 8, 0}, u, y, {}, {}, 0, 1);
  ASSERT_EQ(wh.front_states, 2);
  // The state-space form's recursion written out from rest (the encoder bypassed): the J the split search
  // computed by filtering the blocks one after the other.
  const auto p = ss_parts(wh.model.structure, static_cast<const double*>(wh.model.theta.data()));
  Eigen::VectorXd x = Eigen::VectorXd::Zero(3);
  Eigen::VectorXd y_hat(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    Eigen::VectorXd xu(4);
    xu << x, u(k);
    const Eigen::VectorXd network = p.W2 * (p.W1 * xu + p.b1).array().tanh().matrix() + p.b2;
    y_hat(k) = (p.C * x)(0) + p.D(0, 0) * u(k) + network(3);
    x = p.A * x + p.B * u(k) + network.head(3);
  }
  // The front filter's states are not driven by the network (block structure): its rows of W2 and b2 are 0.
  EXPECT_EQ(p.W2.topRows(2).norm(), 0.0);
  EXPECT_EQ(p.b2.topRows(2).norm(), 0.0);
  EXPECT_NEAR(j_percent(y_hat, y, 100), wh.j_pct, 1e-9 + 1e-6 * wh.j_pct);
}

TEST(SsWienerHammerstein, LevenbergMarquardtRefinesTheBlocksJointly) {
  // The search's nodes are fixed in slope and centre; the refinement moves them, the filters and g together.
  const Eigen::VectorXd u = dsp::uniform_noise(4000, 2.0, 23), y = wh_test_system(u);
  const Eigen::VectorXd ue = u.head(3000), ye = y.head(3000), uv = u.tail(1000), yv = y.tail(1000);
  const LinearModel bla = wh_test_bla();
  const SsWienerHammerstein wh = ss_wiener_hammerstein_start(bla, {3, 4, 8, 0}, ue, ye, uv, yv, 30, 1);
  EXPECT_LT(wh.j_pct, 0.1 * wh.search_j_pct);
  const Eigen::Index init = 20;
  EXPECT_LT(j_percent(wh.model.simulate(uv, yv, init), yv, init), 0.2 * wh.search_j_pct);
}

TEST(SsWienerHammerstein, TheBlockJacobianEqualsCentralFiniteDifferences) {
  // Every parameter of a block model away from any special point (the front filter's poles 0.8 ± 0.4j, the
  // back filter's pole and zero, a constant, a linear term and three tanh nodes): the exact Jacobian the
  // refinement steps with against central differences of the simulated output, column by column.
  WhBlocks blocks;
  blocks.front.a = Eigen::Vector2d(-1.6, 0.8);
  blocks.front.b = Eigen::Vector2d(0.2, 0.05);
  blocks.front.nk = 1;
  blocks.back.a = Eigen::VectorXd::Constant(1, -0.5);
  blocks.back.b = Eigen::Vector2d(1.0, -0.9);
  blocks.back.nk = 0;
  blocks.coefficients = (Eigen::VectorXd(5) << 0.1, 0.7, 0.4, -0.3, 0.25).finished();
  blocks.centres = Eigen::Vector3d(-0.5, 0.1, 0.6);
  blocks.slopes = Eigen::Vector3d(1.5, 2.0, 0.8);
  const Eigen::VectorXd u = dsp::uniform_noise(400, 1.5, 24);
  const Eigen::MatrixXd J = wh_block_jacobian(blocks, u);
  const Eigen::VectorXd theta = blocks.pack();
  ASSERT_EQ(J.rows(), u.size());
  ASSERT_EQ(J.cols(), theta.size());
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    const double h = 1e-5 * (1.0 + std::abs(theta(i)));
    Eigen::VectorXd plus = theta, minus = theta;
    plus(i) += h;
    minus(i) -= h;
    const Eigen::VectorXd fd = (wh_block_output(blocks.unpack(plus), u) - wh_block_output(blocks.unpack(minus), u)) / (2.0 * h);
    EXPECT_LE((J.col(i) - fd).norm(), 1e-6 * fd.norm()) << "parameter " << i;
  }
  EXPECT_THROW(blocks.unpack(theta.head(3)), std::invalid_argument);
}

TEST(SsWienerHammerstein, CandidateSplitsAreRefinedBeforeOneIsKept) {
  // With three candidates refined before one is kept, the kept split is the true one still, and the steps
  // taken in all stay within the budget and lower J as the single candidate's do.
  const Eigen::VectorXd u = dsp::uniform_noise(4000, 2.0, 25), y = wh_test_system(u);
  const Eigen::VectorXd ue = u.head(3000), ye = y.head(3000), uv = u.tail(1000), yv = y.tail(1000);
  const LinearModel bla = wh_test_bla();
  const SsWienerHammerstein one = ss_wiener_hammerstein_start(bla, {3, 4, 8, 0}, ue, ye, uv, yv, 25, 1);
  const SsWienerHammerstein three = ss_wiener_hammerstein_start(bla, {3, 4, 8, 0}, ue, ye, uv, yv, 25, 1, 3);
  EXPECT_EQ(one.candidates, 1);
  EXPECT_EQ(three.candidates, 3);
  EXPECT_EQ(three.front_poles, 2);
  EXPECT_EQ(three.front_zeros, 0);
  EXPECT_LE(three.iterations, 25);
  EXPECT_LT(three.j_pct, 0.1 * three.search_j_pct);
  EXPECT_LT(three.j_pct, 2.0 * one.j_pct);
  EXPECT_THROW(ss_wiener_hammerstein_start(bla, {3, 4, 8, 0}, ue, ye, uv, yv, 5, 1, 0), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

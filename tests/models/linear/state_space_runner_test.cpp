// The one state-space step: its impulse response against a transfer function's written out by hand
// (the direct-form recursion h(k) = b(k) − a1·h(k−1) − a2·h(k−2)), its agreement to the bit with
// models::simulate, a start from a given state, reset, and the shape checks.
#include "models/linear/state_space_runner.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "dsp/random.h"
#include "models/linear/state_space.h"

namespace panelbass::models {
namespace {

// H(z) = (0.5 + 0.2 z⁻¹ − 0.1 z⁻²) z⁻¹ / (1 − 1.2 z⁻¹ + 0.5 z⁻²): poles at radius √0.5, delay 1.
TransferFunction runner_example() {
  TransferFunction tf;
  tf.a = Eigen::Vector2d(-1.2, 0.5);
  tf.b = Eigen::Vector3d(0.5, 0.2, -0.1);
  tf.nk = 1;
  return tf;
}

TEST(StateSpaceRunner, ImpulseResponseIsTheDirectFormRecursionOfTheTransferFunction) {
  StateSpaceRunner runner(realize(runner_example()));
  // By hand: b as a sequence (delay 1) = 0, 0.5, 0.2, −0.1, 0, …; h(k) = b(k) + 1.2·h(k−1) − 0.5·h(k−2).
  const double b[] = {0.0, 0.5, 0.2, -0.1};
  std::vector<double> h(60, 0.0);
  for (std::size_t k = 0; k < h.size(); ++k) {
    h[k] = (k < 4 ? b[k] : 0.0) + (k >= 1 ? 1.2 * h[k - 1] : 0.0) - (k >= 2 ? 0.5 * h[k - 2] : 0.0);
  }
  EXPECT_DOUBLE_EQ(h[1], 0.5);
  EXPECT_DOUBLE_EQ(h[2], 0.2 + 1.2 * 0.5);
  for (std::size_t k = 0; k < h.size(); ++k) {
    EXPECT_NEAR(runner.step(k == 0 ? 1.0 : 0.0), h[k], 1e-12) << k;
  }
}

TEST(StateSpaceRunner, StepBlockIsStepSampleBySampleWithinRoundingForEveryOrder) {
  // Random stable systems (A scaled to spectral norm 0.9) of every order the block loop specialises
  // (up to 4, 8, 12, 16 states) and beyond it, run in uneven blocks against step() on a copy.
  dsp::Rng rng(21);
  for (int n : {0, 1, 3, 4, 5, 8, 9, 12, 16, 17, 23}) {
    StateSpace ss;
    ss.A = Eigen::MatrixXd::NullaryExpr(n, n, [&] { return rng.uniform(-1.0, 1.0); });
    if (n > 0) ss.A *= 0.9 / ss.A.operatorNorm();
    ss.B = Eigen::VectorXd::NullaryExpr(n, [&] { return rng.uniform(-1.0, 1.0); });
    ss.C = Eigen::RowVectorXd::NullaryExpr(n, [&] { return rng.uniform(-1.0, 1.0); });
    ss.D = 0.3;
    StateSpaceRunner by_sample(ss), by_block(ss);
    std::vector<double> u(300), y(300);
    for (double& v : u) v = rng.uniform(-1.0, 1.0);
    std::size_t pos = 0;
    for (std::size_t block : {1, 7, 64, 100, 128}) {
      by_block.step_block({u.data() + pos, block}, {y.data() + pos, block});
      pos += block;
    }
    ASSERT_EQ(pos, u.size());
    for (std::size_t k = 0; k < u.size(); ++k) ASSERT_NEAR(y[k], by_sample.step(u[k]), 1e-13) << n << " states, " << k;
    // The state carries over from a block to the next step.
    EXPECT_NEAR(by_block.step(0.5), by_sample.step(0.5), 1e-13);
    // In place: the output may overwrite the input.
    std::vector<double> again = u;
    by_block.reset();
    by_block.step_block(again, again);
    by_sample.reset();
    for (std::size_t k = 0; k < u.size(); ++k) ASSERT_NEAR(again[k], by_sample.step(u[k]), 1e-13) << n << " states";
  }
}

TEST(StateSpaceRunner, SimulateIsTheRunnerStepBySampleToTheBit) {
  const StateSpace ss = realize(runner_example());
  Eigen::VectorXd u(300);
  for (Eigen::Index k = 0; k < u.size(); ++k) u[k] = std::sin(0.37 * k) + 0.2 * std::cos(1.9 * k);
  const Eigen::VectorXd x0 = Eigen::VectorXd::LinSpaced(ss.order(), 0.3, -0.2);
  const Eigen::VectorXd y = simulate(ss, u, x0);
  StateSpaceRunner runner(ss, x0);
  for (Eigen::Index k = 0; k < u.size(); ++k) ASSERT_EQ(runner.step(u[k]), y[k]) << k;
}

TEST(StateSpaceRunner, StepsFromAGivenStateAndResetsToRest) {
  // x(k+1) = 0.5·x(k) + u(k), y = 2·x + 3·u: from x0 = 1 with u = 0, y = 2, 1, 0.5, …
  StateSpace ss;
  ss.A = Eigen::MatrixXd::Constant(1, 1, 0.5);
  ss.B = Eigen::VectorXd::Constant(1, 1.0);
  ss.C = Eigen::RowVectorXd::Constant(1, 2.0);
  ss.D = 3.0;
  StateSpaceRunner runner(ss, Eigen::VectorXd::Constant(1, 1.0));
  EXPECT_DOUBLE_EQ(runner.step(0.0), 2.0);
  EXPECT_DOUBLE_EQ(runner.step(0.0), 1.0);
  EXPECT_DOUBLE_EQ(runner.state()[0], 0.25);
  runner.reset();
  EXPECT_DOUBLE_EQ(runner.state()[0], 0.0);
  EXPECT_DOUBLE_EQ(runner.step(1.0), 3.0);  // D·u only
  EXPECT_DOUBLE_EQ(runner.step(0.0), 2.0);  // C·B
}

TEST(StateSpaceRunner, AnEmptySystemOutputsZeroAndAPureGainItsGain) {
  StateSpaceRunner none;
  EXPECT_EQ(none.order(), 0);
  EXPECT_EQ(none.step(1.0), 0.0);
  StateSpace gain;
  gain.A.resize(0, 0);
  gain.B.resize(0);
  gain.C.resize(0);
  gain.D = 0.7;
  StateSpaceRunner runner(gain);
  EXPECT_DOUBLE_EQ(runner.step(2.0), 1.4);
}

TEST(StateSpaceRunner, RejectsMismatchedShapesAndInitialStates) {
  StateSpace ss = realize(runner_example());
  EXPECT_THROW(StateSpaceRunner(ss, Eigen::VectorXd::Zero(ss.order() + 1)), std::invalid_argument);
  ss.B.resize(ss.order() + 1);
  EXPECT_THROW(StateSpaceRunner{ss}, std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

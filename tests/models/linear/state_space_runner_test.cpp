// The one state-space step: its impulse response against a transfer function's written out by hand
// (the direct-form recursion h(k) = b(k) − a1·h(k−1) − a2·h(k−2)), its agreement to the bit with
// models::simulate, a start from a given state, reset, and the shape checks.
#include "models/linear/state_space_runner.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>
#include <vector>

#include "dsp/random.h"
#include "models/linear/state_space.h"

namespace panelbass::models {
namespace {

// H(z) = (0.5 + 0.2 z⁻¹ − 0.1 z⁻²) z⁻¹ / (1 − 1.2 z⁻¹ + 0.5 z⁻²): poles at radius √0.5, delay 1.
TransferFunction example() {
  TransferFunction tf;
  tf.a = Eigen::Vector2d(-1.2, 0.5);
  tf.b = Eigen::Vector3d(0.5, 0.2, -0.1);
  tf.nk = 1;
  return tf;
}

TEST(StateSpaceRunner, ImpulseResponseIsTheDirectFormRecursionOfTheTransferFunction) {
  StateSpaceRunner runner(realize(example()));
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

// An 8th-order system with four resonances (engine_bench's feedforward, radii 0.9..0.97, 50..900 Hz at 3 kHz)
// and, when `real_poles`, three real poles beside them (an odd count: one modal pair half padding).
StateSpace runner_resonant_system(bool real_poles) {
  Eigen::VectorXcd poles(real_poles ? 11 : 8);
  const double hz[] = {50.0, 200.0, 500.0, 900.0};
  const double radius[] = {0.97, 0.95, 0.92, 0.9};
  for (int i = 0; i < 4; ++i) {
    poles[2 * i] = std::polar(radius[i], 2.0 * 3.141592653589793 * hz[i] / 3000.0);
    poles[2 * i + 1] = std::conj(poles[2 * i]);
  }
  if (real_poles) poles.tail(3) << 0.5, -0.3, 0.8;
  TransferFunction tf;
  tf.a = polynomial_from_roots(poles).tail(poles.size()).real();
  tf.b = Eigen::VectorXd::LinSpaced(poles.size(), 0.01, -0.02);
  return realize(tf);
}

TEST(StateSpaceRunner, TheModalBlockFormIsStepWithinRoundingAndCarriesTheStateOn) {
  // Complex pole pairs, and real poles beside them: step_block in modal coordinates against step() on a
  // copy, in uneven blocks, in place, and from a state left by step().
  dsp::Rng rng(41);
  for (const bool real_poles : {false, true}) {
    const StateSpace ss = runner_resonant_system(real_poles);
    StateSpaceRunner by_sample(ss), by_block(ss, {}, BlockForm::modal);
    ASSERT_TRUE(by_block.uses_modal_form()) << real_poles;
    EXPECT_FALSE(by_sample.uses_modal_form());
    std::vector<double> u(3000), y(u.size()), expected(u.size());
    for (double& v : u) v = rng.uniform(-1.0, 1.0);
    for (std::size_t k = 0; k < u.size(); ++k) expected[k] = by_sample.step(u[k]);
    y = u;
    std::size_t pos = 0;
    for (std::size_t block : {1, 7, 64, 100, 128, 3, 1697, 1000}) {
      by_block.step_block({y.data() + pos, block}, {y.data() + pos, block});
      pos += block;
    }
    ASSERT_EQ(pos, u.size());
    double peak = 0.0, worst = 0.0;
    for (std::size_t k = 0; k < u.size(); ++k) {
      peak = std::max(peak, std::abs(expected[k]));
      worst = std::max(worst, std::abs(y[k] - expected[k]));
    }
    EXPECT_LE(worst, 1e-12 * peak) << real_poles;
    // The state comes back from modal coordinates: the next steps agree too.
    for (int k = 0; k < 10; ++k) EXPECT_NEAR(by_block.step(0.5), by_sample.step(0.5), 1e-12 * peak);
  }
}

TEST(StateSpaceRunner, ADefectiveOrIllConditionedSystemKeepsItsOwnCoordinates) {
  // A Jordan block (a double pole with one eigenvector) has no modal form; two almost equal poles have one
  // too ill conditioned to trust. Both run as given, still equal to step().
  StateSpace jordan;
  jordan.A = (Eigen::Matrix2d() << 0.5, 1.0, 0.0, 0.5).finished();
  jordan.B = Eigen::Vector2d(0.0, 1.0);
  jordan.C = Eigen::RowVector2d(1.0, 0.0);
  StateSpace close = jordan;
  close.A(1, 1) = 0.5 + 1e-9;
  for (const StateSpace& ss : {jordan, close}) {
    StateSpaceRunner by_sample(ss), by_block(ss, {}, BlockForm::modal);
    EXPECT_FALSE(by_block.uses_modal_form());
    std::vector<double> y(50, 0.0);
    y[0] = 1.0;
    by_block.step_block(y, y);
    for (std::size_t k = 0; k < y.size(); ++k) EXPECT_NEAR(y[k], by_sample.step(k == 0 ? 1.0 : 0.0), 1e-14) << k;
  }
}

TEST(StateSpaceRunner, SimulateIsTheRunnerStepBySampleToTheBit) {
  const StateSpace ss = realize(example());
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
  StateSpace ss = realize(example());
  EXPECT_THROW(StateSpaceRunner(ss, Eigen::VectorXd::Zero(ss.order() + 1)), std::invalid_argument);
  ss.B.resize(ss.order() + 1);
  EXPECT_THROW(StateSpaceRunner{ss}, std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

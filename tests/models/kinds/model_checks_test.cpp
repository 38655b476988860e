// A model's own checks against independent expectations: poles placed by hand just inside and just outside
// the unit circle, an LQ loop whose scalar closed-loop pole is written down, and NARX models that are
// linear recursions whose free runs follow a closed form.

#include "models/kinds/model_checks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace panelbass::models {
namespace {

// A(z) = 1 − 2r·cos θ·z⁻¹ + r²·z⁻²: the pole pair r·e^{±jθ}.
TransferFunction pole_pair(double r, double theta) {
  TransferFunction tf;
  tf.a = Eigen::Vector2d(-2.0 * r * std::cos(theta), r * r);
  tf.b = Eigen::VectorXd::Ones(1);
  return tf;
}

TEST(ModelChecks, PolesJustInsideTheUnitCircleAreStable) {
  EXPECT_FALSE(unstable_pole(pole_pair(0.999, 0.3), 1000.0));
  TransferFunction fir;
  fir.b = Eigen::Vector3d(1.0, 0.5, 0.25);
  EXPECT_FALSE(unstable_pole(fir, 1000.0)) << "an FIR has no poles";
}

TEST(ModelChecks, APoleJustOutsideIsNamedWithItsRadiusAndFrequency) {
  // θ = 2π·100/1000: the pair sits at 100 Hz for fs = 1000 Hz.
  const std::optional<UnstablePole> pole = unstable_pole(pole_pair(1.001, 2.0 * std::numbers::pi * 0.1), 1000.0);
  ASSERT_TRUE(pole);
  EXPECT_NEAR(pole->radius, 1.001, 1e-12);
  EXPECT_NEAR(pole->hz, 100.0, 1e-9);
  // On the circle counts as unstable; without a rate the frequency is unknown.
  TransferFunction integrator;
  integrator.a = Eigen::VectorXd::Constant(1, -1.0);
  integrator.b = Eigen::VectorXd::Ones(1);
  const std::optional<UnstablePole> on = unstable_pole(integrator, std::nan(""));
  ASSERT_TRUE(on);
  EXPECT_DOUBLE_EQ(on->radius, 1.0);
  EXPECT_TRUE(std::isnan(on->hz));
}

TEST(ModelChecks, AnLqLoopIsJudgedByThePoleOfAMinusBL) {
  // Scalar loop: A − B·L = 0.5 − L.
  const Eigen::MatrixXd A = Eigen::MatrixXd::Constant(1, 1, 0.5);
  const Eigen::VectorXd B = Eigen::VectorXd::Ones(1);
  EXPECT_FALSE(unstable_lq_radius(A, B, Eigen::VectorXd::Constant(1, -0.4)));  // pole 0.9
  const std::optional<double> radius = unstable_lq_radius(A, B, Eigen::VectorXd::Constant(1, -0.6));  // pole 1.1
  ASSERT_TRUE(radius);
  EXPECT_NEAR(*radius, 1.1, 1e-12);
}

// y(k) = g·y(k−1) + c, the input ignored: a NARX network with no hidden layer (θ = [w_y, w_u, bias]).
NarxModel recursion(double g, double c) {
  NarxModel m = NarxModel::with_structure({1, 0, 0, {}}, Scaling{}, 1000.0);
  m.net.parameters() = Eigen::Vector3d(g, 0.0, c);
  return m;
}

TEST(ModelChecks, ADivergingFreeRunIsCaughtWhereItLeavesTheBound) {
  // y(k) = 2·y(k−1) + 1 from rest: y = 2^k − 1 (k from 1), so 127 at the 7th sample is the first beyond 100.
  const std::optional<Runaway> run = free_run_runaway(recursion(2.0, 1.0));
  ASSERT_TRUE(run);
  EXPECT_EQ(run->samples, 7);
  EXPECT_DOUBLE_EQ(run->magnitude, 127.0);
  // y(k) = 0.5·y(k−1) + 1 tends to 2 and never leaves the bound.
  EXPECT_FALSE(free_run_runaway(recursion(0.5, 1.0)));
}

TEST(ModelChecks, ARunawayIsTheFirstSampleNotFiniteOrBeyondTheBound) {
  EXPECT_FALSE(runaway(Eigen::Vector3d(0.0, -kFreeRunBound, kFreeRunBound)));
  const std::optional<Runaway> nan = runaway(Eigen::Vector3d(1.0, std::nan(""), 1e9));
  ASSERT_TRUE(nan);
  EXPECT_EQ(nan->samples, 2);
  EXPECT_TRUE(std::isnan(nan->magnitude));
}

TEST(ModelChecks, TheFreeRunDriveIsTheSameFullScaleNoiseEveryTime) {
  const Eigen::VectorXd u = free_run_drive();
  EXPECT_EQ(u.size(), kFreeRunSamples);
  EXPECT_TRUE(u.isApprox(free_run_drive()));
  EXPECT_LE(u.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_GT(u.cwiseAbs().maxCoeff(), 0.99) << "spans the scaled input range";
}

}  // namespace
}  // namespace panelbass::models

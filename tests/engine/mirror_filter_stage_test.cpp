// The mirror filter as a chain stage: built from its model file by the stage factory, it runs exactly the
// model's filter (models/control/mirror_filter.h) sample by sample, and refuses a chain at another rate.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>

#include "engine/mirror_filter_stage.h"
#include "engine/stage_factory.h"
#include "models/control/mirror_filter.h"

namespace panelbass::engine {
namespace {

models::MirrorModel small_model() {
  models::MirrorModel m;
  m.fs = 3000.0;
  m.electrical = {1.5e-5, 0.0, 0.0, -3e-7, 0.2, 7.5e-5, 0.0, -3.4e-5, 0.0, 0.0};
  m.mechanical = {1.5e5, 0.0, -6.75e4, 0.0, 0.0, -40.0, -8.88e5, -2.66e4, -5.33e4, -5000.0};
  m.friction_velocity = 50.0;
  return m;
}

TEST(MirrorFilterStage, FactoryStageRunsTheModelsFilter) {
  const models::MirrorModel model = small_model();
  std::unique_ptr<Stage> stage = make_stage(models::mirror_model_to_json(model), models::ModelRole::feedforward);
  stage->prepare({3000.0, 64});
  Eigen::VectorXd program(600);
  for (Eigen::Index k = 0; k < program.size(); ++k) program[k] = 0.4 * std::sin(2.0 * std::numbers::pi * 80.0 * k / 3000.0);
  const Eigen::VectorXd expected = models::mirror_filter(model, program);
  for (Eigen::Index k = 0; k < program.size(); ++k) EXPECT_DOUBLE_EQ(stage->process(program[k]), expected[k]);
}

TEST(MirrorFilterStage, AdaptiveStageFindsTheStiffnessOfThePlantItDrives) {
  // the stage closed over a plant its model describes exactly but for a stiffness 1.44 times the model's (the
  // resonance 1.2 times higher), the sensor [S1] a scaled difference of the velocity, noise-free: the stage's
  // observer finds the plant's stiffness from the sensor alone and keeps the others at 1
  models::MirrorModel model = small_model();
  model.observer = {true, {2e-3, -2e-3, 0.0, 0.0}, 1e-3, 1.0, 1e-4, 0.3, 1e-4, 0.1, 1e-4, 0.3};
  models::MirrorModel plant = model;
  for (std::size_t j : {6u, 7u, 8u}) plant.mechanical[j] *= 1.44;
  MirrorFilterStage stage(model);
  EXPECT_TRUE(stage.observes());
  EXPECT_FALSE(MirrorFilterStage(small_model()).observes());
  stage.prepare({3000.0, 64});
  models::MirrorState s;
  std::array<double, 4> v{};  // the plant's velocity rows k..k−3
  for (int k = 0; k < 6000; ++k) {
    const double program = 0.2 * std::sin(2.0 * std::numbers::pi * 60.0 * k / 3000.0) +
                           0.1 * std::sin(2.0 * std::numbers::pi * 170.0 * k / 3000.0);
    const double drive = stage.process(program);
    // delay 0: the drive of sample k takes the plant's row k to row k + 1; the sensor reads rows k..k−3
    stage.observe(2e-3 * (v[0] - v[1]));
    models::step_mirror_model(plant, s, drive);
    v = {s.v, v[0], v[1], v[2]};
  }
  ASSERT_NE(stage.observer(), nullptr);
  EXPECT_NEAR(stage.observer()->scales().stiffness, 1.44, 0.015);
  EXPECT_NEAR(stage.observer()->scales().force, 1.0, 0.01);
  EXPECT_NEAR(stage.observer()->scales().nonlinear, 1.0, 0.03);
}

TEST(MirrorFilterStage, AdaptiveStageWithoutASensorKeepsItsModel) {
  // a chain run without a sensor observes zeros: the adaptive stage then gives what the open-loop filter gives
  models::MirrorModel model = small_model();
  model.observer = {true, {2e-3, -2e-3, 0.0, 0.0}, 1e-3, 1.0, 1e-4, 0.3, 1e-4, 0.1, 1e-4, 0.3};
  MirrorFilterStage stage(model);
  stage.prepare({3000.0, 64});
  Eigen::VectorXd program(3000);
  for (Eigen::Index k = 0; k < program.size(); ++k) program[k] = 0.3 * std::sin(2.0 * std::numbers::pi * 80.0 * k / 3000.0);
  const Eigen::VectorXd expected = models::mirror_filter(small_model(), program);
  for (Eigen::Index k = 0; k < program.size(); ++k) {
    ASSERT_DOUBLE_EQ(stage.process(program[k]), expected[k]) << "sample " << k;
    stage.observe(0.0);
  }
}

TEST(MirrorFilterStage, RefusesAnotherRate) {
  MirrorFilterStage stage(small_model());
  EXPECT_THROW(stage.prepare({48000.0, 64}), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::engine

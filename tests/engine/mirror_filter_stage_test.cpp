// The mirror filter as a chain stage: built from its model file by the stage factory, it runs exactly the
// model's filter (models/control/mirror_filter.h) sample by sample, and refuses a chain at another rate.
#include <gtest/gtest.h>

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
  std::unique_ptr<Stage> stage = make_stage(models::mirror_model_to_json(model), FeedbackSource::model);
  stage->prepare({3000.0, 64});
  Eigen::VectorXd program(600);
  for (Eigen::Index k = 0; k < program.size(); ++k) program[k] = 0.4 * std::sin(2.0 * std::numbers::pi * 80.0 * k / 3000.0);
  const Eigen::VectorXd expected = models::mirror_filter(model, program);
  for (Eigen::Index k = 0; k < program.size(); ++k) EXPECT_DOUBLE_EQ(stage->process(program[k]), expected[k]);
}

TEST(MirrorFilterStage, RefusesAnotherRate) {
  MirrorFilterStage stage(small_model());
  EXPECT_THROW(stage.prepare({48000.0, 64}), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::engine

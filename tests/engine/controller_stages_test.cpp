// The controllers as engine stages: the LQ feedforward controller's state space run per sample, the
// neural feedback controller in model and sensor mode, and the stage factory's dispatch on the kind.
#include <gtest/gtest.h>

#include "engine/chain.h"
#include "engine/controller_stages.h"
#include "engine/stage_factory.h"
#include "models/io/config_error.h"
#include "models/control/feedback_training.h"
#include "models/control/lq_feedforward.h"
#include "models/control/neural_feedback.h"
#include "tests/engine/engine_test_models.h"

namespace panelbass::engine {
namespace {

using testing::kFs;

// `u` through `stage` prepared at the model rate, sample by sample.
Eigen::VectorXd run_prepared(Stage& stage, const Eigen::VectorXd& u) {
  stage.prepare(ProcessSpec{kFs, 64});
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) y[k] = stage.process(u[k]);
  return y;
}

// A neural feedback controller (nu 2, nv 2, ny 3, 5 nodes) with weights large enough to matter.
models::NeuralFeedback example_feedback() {
  models::FeedbackStructure s;
  s.nu = 2;
  s.nv = 2;
  s.ny = 3;
  s.hidden = {5};
  return testing::example_feedback(s, 4, 9, 1.0);
}

TEST(ControllerStagesTest, LqFeedforwardStageIsTheStateSpaceOf7B) {
  const models::LqFeedforward ff = models::design_lq(testing::example_linear(), {1e-3, 20.0});
  const std::unique_ptr<Stage> stage = make_stage(models::lq_feedforward_to_json(ff), models::ModelRole::feedforward);
  const Eigen::VectorXd u = testing::uniform(500, 0.5, 1);
  const Eigen::VectorXd out = run_prepared(*stage, u);
  // [7B] written out: x(k+1) = (A − BL)x(k) + Bu(k), u*(k) = −Lx(k) + u(k), with the plant's A, B and L
  const models::StateSpace& p = ff.plant;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(p.order());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    const double expected = -ff.L.dot(x) + u[k];
    ASSERT_NEAR(out[k], expected, 1e-12 * (1.0 + std::abs(expected))) << k;
    x = (p.A - p.B * ff.L) * x + p.B * u[k];
  }
}

TEST(ControllerStagesTest, AStateSpaceStageHasTheLinearStagesStateCap) {
  models::StateSpace ss;
  const Eigen::Index n = kMaxStageStates + 1;
  ss.A = 0.5 * Eigen::MatrixXd::Identity(n, n);
  ss.B = Eigen::VectorXd::Ones(n);
  ss.C = Eigen::RowVectorXd::Ones(n);
  EXPECT_THROW(StateSpaceStage(ss, kFs), models::ConfigError);
  ss.A = 0.5 * Eigen::MatrixXd::Identity(n - 1, n - 1);
  ss.B = Eigen::VectorXd::Ones(n - 1);
  ss.C = Eigen::RowVectorXd::Ones(n - 1);
  StateSpaceStage stage(ss, kFs);
  stage.prepare(ProcessSpec{kFs, 64});
  EXPECT_DOUBLE_EQ(stage.process(1.0), 0.0);
  EXPECT_DOUBLE_EQ(stage.process(0.0), static_cast<double>(n - 1));  // C·B
}

TEST(ControllerStagesTest, NeuralFeedbackStageInModelModeIsTheClosedLoopOfItsPlantModel) {
  const models::NeuralFeedback c = example_feedback();
  NeuralFeedbackStage stage(c, FeedbackSource::model);
  const Eigen::VectorXd u = testing::uniform(800, 0.9, 2);
  const Eigen::VectorXd v = run_prepared(stage, u);
  const models::ClosedLoopRun expected = models::simulate_closed_loop(c, u);
  EXPECT_LT((v - expected.v).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE(v.cwiseAbs().maxCoeff(), 1.0);
}

TEST(ControllerStagesTest, SensorModeFedThePlantModelsOutputMatchesModelMode) {
  const models::NeuralFeedback c = example_feedback();
  const Eigen::VectorXd u = testing::uniform(600, 0.7, 3);
  const models::ClosedLoopRun loop = models::simulate_closed_loop(c, u);
  NeuralFeedbackStage stage(c, FeedbackSource::sensor);
  stage.prepare(ProcessSpec{kFs, 64});
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    ASSERT_NEAR(stage.process(u[k]), loop.v[k], 1e-12) << k;
    stage.observe(loop.y[k]);  // the "sensor" reads what the plant model produced
  }
  // a different sensor signal changes the drive: the stage really reads it
  stage.reset();
  double difference = 0.0;
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    difference = std::max(difference, std::abs(stage.process(u[k]) - loop.v[k]));
    stage.observe(0.0);
  }
  EXPECT_GT(difference, 1e-6);
}

// The registry (models/kinds) says which kinds a slot takes: a plant model runs in neither slot, a controller only in
// its own, and each refusal names what the model is and what the slot takes.
TEST(ControllerStagesTest, FactoryBuildsEveryControllerInItsSlotAndRefusesOthers) {
  const models::NeuralFeedback c = example_feedback();
  const std::unique_ptr<Stage> fb =
      make_stage(models::neural_feedback_to_json(c), models::ModelRole::feedback, FeedbackSource::model);
  const Eigen::VectorXd u = testing::uniform(200, 0.5, 4);
  EXPECT_LT((run_prepared(*fb, u) - models::simulate_closed_loop(c, u).v).cwiseAbs().maxCoeff(), 1e-12);
  const nlohmann::json linear = models::linear_model_to_json(testing::example_linear());
  for (const auto slot : {models::ModelRole::feedforward, models::ModelRole::feedback}) {
    try {
      (void)make_stage(linear, slot);
      ADD_FAILURE() << "a linear plant model was accepted in the " << models::role_name(slot) << " slot";
    } catch (const models::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("a linear plant model (kind linear)"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(std::string("the ") + models::role_name(slot) + " slot takes"), std::string::npos)
          << e.what();
    }
  }
  EXPECT_THROW(make_stage(models::neural_feedback_to_json(c), models::ModelRole::feedforward), models::ConfigError);
  const models::LqFeedforward ff = models::design_lq(testing::example_linear(), {1e-3, 20.0});
  EXPECT_THROW(make_stage(models::lq_feedforward_to_json(ff), models::ModelRole::feedback), models::ConfigError);
  EXPECT_THROW(make_stage(nlohmann::json{{"kind", "pid"}}, models::ModelRole::feedforward), models::ConfigError);
  EXPECT_THROW(make_stage(nlohmann::json{{"fs", 3000}}, models::ModelRole::feedforward), models::ConfigError);
  nlohmann::json wrong_rate = models::neural_feedback_to_json(c);
  const std::unique_ptr<Stage> at_3k = make_stage(wrong_rate, models::ModelRole::feedback);
  EXPECT_THROW(at_3k->prepare(ProcessSpec{48000.0, 64}), std::invalid_argument);
}

TEST(ControllerStagesTest, ASilentSensorIsReplacedByThePlantModelAndReportedOnce) {
  const models::NeuralFeedback c = example_feedback();
  const Eigen::VectorXd u = testing::uniform(2400, 0.7, 5);
  const models::ClosedLoopRun loop = models::simulate_closed_loop(c, u);
  NeuralFeedbackStage stage(c, FeedbackSource::sensor);
  stage.prepare(ProcessSpec{kFs, 64});
  // The sensor reads the plant (model) until sample 600, nothing from 600 to 1499, a signal again after.
  const auto reading = [&loop](Eigen::Index k) { return k >= 600 && k < 1500 ? 0.0 : loop.y[k]; };
  std::vector<Eigen::Index> faults;
  Eigen::Index lost_from = -1, back_from = -1;
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    const double v = stage.process(u[k]);
    ASSERT_TRUE(std::isfinite(v));
    ASSERT_LE(std::abs(v), 1.0);
    if (k < 600) {
      ASSERT_NEAR(v, loop.v[k], 1e-12) << k;
    }
    stage.observe(reading(k));
    if (stage.take_fault() == Fault::sensor_lost) faults.push_back(k);
    if (stage.on_model_fallback() && lost_from < 0) lost_from = k;
    if (!stage.on_model_fallback() && lost_from >= 0 && back_from < 0) back_from = k;
  }
  // 0.1 s at 3 kHz = 300 samples of silence while the model predicts signal; as long to come back.
  EXPECT_EQ(faults, std::vector<Eigen::Index>{899});
  EXPECT_EQ(lost_from, 899);
  EXPECT_EQ(back_from, 1799);
}

TEST(ControllerStagesTest, TheChainRecordsALostSensorWithoutBypassingAnything) {
  const models::NeuralFeedback c = example_feedback();
  ChainOptions options;
  Chain chain(options);
  chain.feedback().set_initial(std::make_unique<NeuralFeedbackStage>(c, FeedbackSource::sensor));
  const Eigen::VectorXd u = testing::uniform(3000, 0.5, 6);
  std::vector<double> drive(64);
  // A sensor that reads a scaled copy of the drive for 0.5 s, then nothing.
  std::size_t sample = 0;
  for (Eigen::Index pos = 0; pos + 64 <= u.size(); pos += 64) {
    chain.process_block(std::span<const double>(u.data() + pos, 64), drive, [&sample](double d) noexcept {
      return sample++ < 1500 ? 0.8 * d : 0.0;
    });
    for (const double d : drive) ASSERT_LE(std::abs(d), 1.0);
  }
  const MetricsSnapshot m = chain.metrics().snapshot();
  EXPECT_EQ(m.faults, 1u);
  EXPECT_EQ(m.last_fault, Fault::sensor_lost);
  EXPECT_FALSE(m.in_fault);  // the feedback runs on its plant model; nothing is bypassed
}

}  // namespace
}  // namespace panelbass::engine

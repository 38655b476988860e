// Stages against independent evaluations: the band-pass against a directly designed SosFilter, the
// linear stage against LinearModel::simulate, the NARX stage against NarxModel::simulate (model mode)
// and NarxModel::predict (sensor mode), and warm-up against an uninterrupted run.
#include "engine/stage.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "dsp/butterworth.h"
#include "tests/engine/engine_test_models.h"
#include "tests/support/model_stages.h"

namespace panelbass::engine {
namespace {

using testing::kFs;

// A NARX structure with an input delay and two hidden layers: na = 3, nb = 5, nk = 2, 9 and 6 nodes.
models::NarxStructure delayed_two_layer_structure() {
  models::NarxStructure st;
  st.na = 3;
  st.nb = 5;
  st.nk = 2;
  st.hidden = {9, 6};
  return st;
}

// out[k] = stage.process(u[k]), observing measured[k] after each sample when given.
Eigen::VectorXd run(Stage& stage, const Eigen::VectorXd& u, const Eigen::VectorXd& measured = {}) {
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    y[k] = stage.process(u[k]);
    if (measured.size() > 0) stage.observe(measured[k]);
  }
  return y;
}

TEST(BandPassStage, EqualsTheButterworthSosFilterDesignedDirectly) {
  const Eigen::VectorXd u = testing::uniform(2000, 1.0, 1);
  BandPassStage stage;
  stage.prepare({kFs, 64});
  // The default corners: 20–1200 Hz, second order each side, at the model rate.
  dsp::SosFilter reference(dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs));
  EXPECT_EQ((run(stage, u) - reference.process(u)).cwiseAbs().maxCoeff(), 0.0);
}

TEST(BandPassStage, TakesItsCornersAndOrderFromTheDesign) {
  const Eigen::VectorXd u = testing::uniform(1000, 1.0, 2);
  BandPassStage stage({Hertz{50.0}, Hertz{400.0}, 3});
  stage.prepare({kFs, 64});
  dsp::SosFilter reference(dsp::butterworth_bandpass(3, 50.0, 400.0, kFs));
  EXPECT_EQ((run(stage, u) - reference.process(u)).cwiseAbs().maxCoeff(), 0.0);
  stage.reset();
  reference.reset();
  EXPECT_EQ(stage.process(1.0), reference.process(1.0));
}

TEST(BandPassStage, RejectsACornerAboveNyquist) {
  BandPassStage stage({Hertz{20.0}, Hertz{1600.0}, 2});
  EXPECT_THROW(stage.prepare({kFs, 64}), std::invalid_argument);
}

TEST(LinearStage, EqualsLinearModelSimulateInRawUnits) {
  const models::LinearModel m = testing::example_linear();
  const Eigen::VectorXd u = testing::uniform(3000, 0.5, 3);
  LinearStage stage(m);
  stage.prepare({kFs, 64});
  const Eigen::VectorXd expected = m.simulate(u);
  EXPECT_LE((run(stage, u) - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
}

TEST(LinearStage, RefusesAChainAtAnotherRate) {
  LinearStage stage(testing::example_linear());
  try {
    stage.prepare({48000.0, 64});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("3000"), std::string::npos) << e.what();
  }
}

TEST(NarxStage, ModelModeEqualsNarxModelSimulate) {
  const models::NarxModel m = testing::example_narx(3);
  const Eigen::VectorXd u = testing::uniform(2000, 1.0, 4);
  NarxStage stage(m, FeedbackSource::model);
  stage.prepare({kFs, 64});
  const Eigen::VectorXd expected = m.simulate(u);
  EXPECT_LE((run(stage, u) - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
}

TEST(NarxStage, SensorModeEqualsNarxModelPredictFromTheMeasuredOutputs) {
  const models::NarxModel m = testing::example_narx(5);
  const Eigen::VectorXd u = testing::uniform(2000, 1.0, 6);
  const Eigen::VectorXd measured = testing::uniform(2000, 0.5, 7);
  NarxStage stage(m, FeedbackSource::sensor);
  stage.prepare({kFs, 64});
  const Eigen::VectorXd expected = m.predict(u, measured);
  EXPECT_LE((run(stage, u, measured) - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
}

TEST(NarxStage, TheThesisSizeAndTwoHiddenLayersEqualTheModelsOwnSimulationInBothModes) {
  // NN 17-17-1 (na = nb = 8) and a two-layer net with a delay, large weights so every tanh bends: the
  // stage's kernel (padded column-major weights, vectorised tanh) and ring histories against
  // NarxModel::simulate and ::predict, which run Mlp::forward on regressors built from the whole record.
  const models::NarxStructure two_layers = delayed_two_layer_structure();
  for (const models::NarxStructure& st : {models::NarxStructure{}, two_layers}) {
    models::NarxModel m = models::NarxModel::with_structure(st, {0.01, 0.9, -0.02, 0.8}, kFs);
    m.net.initialize(1.0, 17, 2.0);
    const Eigen::VectorXd u = testing::uniform(5000, 1.0, 18);
    const Eigen::VectorXd measured = testing::uniform(5000, 0.5, 19);
    NarxStage model_mode(m, FeedbackSource::model), sensor_mode(m, FeedbackSource::sensor);
    model_mode.prepare({kFs, 64});
    sensor_mode.prepare({kFs, 64});
    const Eigen::VectorXd simulated = m.simulate(u), predicted = m.predict(u, measured);
    EXPECT_LE((run(model_mode, u) - simulated).cwiseAbs().maxCoeff(), 1e-12 * simulated.cwiseAbs().maxCoeff());
    EXPECT_LE((run(sensor_mode, u, measured) - predicted).cwiseAbs().maxCoeff(),
              1e-12 * predicted.cwiseAbs().maxCoeff());
  }
}

TEST(NarxStage, ABlockInModelModeIsProcessSampleBySampleToTheBit) {
  // process_block's free run (the feedback kept in registers) against process() per sample on a copy, for
  // the thesis's NN 17-17-1, a delay with a two-layer net, and a net without a hidden layer, in uneven blocks.
  const models::NarxStructure two_layers = delayed_two_layer_structure();
  models::NarxStructure linear;
  linear.na = 2;
  linear.nb = 1;
  linear.hidden = {};
  for (const models::NarxStructure& st : {models::NarxStructure{}, two_layers, linear}) {
    models::NarxModel m = models::NarxModel::with_structure(st, {0.01, 0.9, -0.02, 0.8}, kFs);
    m.net.initialize(1.0, 23, 2.0);
    const Eigen::VectorXd u = testing::uniform(1000, 1.0, 24);
    NarxStage by_sample(m, FeedbackSource::model), by_block(m, FeedbackSource::model);
    by_sample.prepare({kFs, 128});
    by_block.prepare({kFs, 128});
    const Eigen::VectorXd expected = run(by_sample, u);
    std::vector<double> y(u.data(), u.data() + u.size());
    std::size_t pos = 0;
    for (std::size_t block : {1, 64, 7, 128, 100, 64, 128, 128, 128, 128, 124}) {
      by_block.process_block({y.data() + pos, block}, {y.data() + pos, block});  // in place
      pos += block;
    }
    ASSERT_EQ(pos, y.size());
    for (Eigen::Index k = 0; k < u.size(); ++k) ASSERT_EQ(y[static_cast<std::size_t>(k)], expected[k]) << k;
    // The state goes on from the block: the next sample equals the per-sample stage's.
    EXPECT_EQ(by_block.process(0.3), by_sample.process(0.3));
  }
}

TEST(Stage, WarmUpFromRecentHistoryContinuesAnUninterruptedRun) {
  const models::LinearModel m = testing::example_linear();
  const Eigen::VectorXd u = testing::uniform(1200, 0.5, 8);
  const Eigen::VectorXd zeros = Eigen::VectorXd::Zero(u.size());
  LinearStage all_along(m), warmed(m);
  all_along.prepare({kFs, 64});
  warmed.prepare({kFs, 64});
  const Eigen::VectorXd expected = run(all_along, u);
  // 700 samples of history: the slowest pole (0.95) has forgotten the start by 0.95^700 ≈ 3e-16.
  const double last = warmed.warm_up({u.data() + 300, 700}, {zeros.data() + 300, 700});
  EXPECT_NEAR(last, expected[999], 1e-12);
  const Eigen::VectorXd rest = run(warmed, u.tail(200));
  EXPECT_LE((rest - expected.tail(200)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(PassThroughStage, ReturnsItsInput) {
  PassThroughStage stage;
  stage.prepare({kFs, 64});
  EXPECT_EQ(stage.process(0.25), 0.25);
}

}  // namespace
}  // namespace panelbass::engine

// The analysis against independent expectations: an exact linear model of a noisy ARX-free system leaves
// the noise, so J_sim ≈ σ²/mean(y²) and the coherence floor agrees with it; the OE refinement's first J
// equals j_percent of the model simulated from rest; an output of pure noise is all non-coherent
// (J_noncoherent ≈ 100 %); histories are read from the three JSON shapes with key paths in errors.
#include "models/analysis/model_analysis.h"

#include <gtest/gtest.h>

#include <cmath>

#include "models/io/config_error.h"
#include "models/validation/performance.h"
#include "tests/support/expect_error.h"
#include "tests/support/linear_systems.h"
#include "tests/support/vectors.h"

namespace panelbass::models {
namespace {

using testing_support::gaussian;
using testing_support::vec;

// A damped resonance with a delay of 2 samples, scaled units = raw units.
AnyModel resonance_model() {
  LinearModel m;
  m.tf.a = vec({-1.6, 0.8});
  m.tf.b = vec({0.5, 0.2});
  m.tf.nk = 2;
  m.fs = 3000.0;
  m.method = "oe";
  return AnyModel{m};
}

TEST(ModelAnalysis, ExactModelLeavesTheNoiseAndTheFloorsAgree) {
  const AnyModel model = resonance_model();
  const LinearModel& lm = std::get<LinearModel>(model.model);
  const Eigen::VectorXd u = gaussian(8192, 1.0, 1);
  const Eigen::VectorXd clean = testing_support::simulate(lm.tf, u);
  const double sigma = 0.05 * std::sqrt(clean.squaredNorm() / clean.size());
  const Eigen::VectorXd y = clean + gaussian(u.size(), sigma, 2);

  AnalysisSpec spec;
  spec.init = 0;
  spec.refine_iterations = 5;
  const ModelAnalysis a = analyze_model(model, u, y, spec);
  const double noise_j = 100.0 * sigma * sigma / (y.squaredNorm() / y.size());  // ≈ 0.25 %
  EXPECT_NEAR(a.j_sim_pct, noise_j, 0.15 * noise_j);
  // The true system is linear: what is not coherent is the noise (up to leakage and averaging bias).
  EXPECT_NEAR(a.j_noncoherent_pct, noise_j, 0.5 * noise_j);
  EXPECT_TRUE(a.residual_tests.input_tests_pass) << a.residual_tests.explanation;
  ASSERT_TRUE(a.pole_zero.has_value());
  EXPECT_EQ(a.pole_zero->poles.size(), 2);
  EXPECT_LE(a.pole_zero->best.max_radius, a.pole_zero->open_loop.max_radius);
  ASSERT_TRUE(a.history.has_value());
  // Iteration 0 is the model itself from rest: [2A] on the raw data.
  EXPECT_NEAR(a.history->points.front().j_est_pct, j_percent(lm.simulate(u), y), 1e-9);
  // The model's FRF is the transfer function's at the Welch bins.
  EXPECT_NEAR(std::abs(a.frf.model[10] - lm.tf.response(a.frf.frequency[10], 3000.0)), 0.0, 1e-12);
}

TEST(ModelAnalysis, PureNoiseOutputIsAllNonCoherent) {
  const Eigen::VectorXd u = gaussian(8192, 1.0, 3);
  const Eigen::VectorXd y = gaussian(8192, 1.0, 4);
  AnalysisSpec spec;
  spec.init = 0;
  spec.refine_iterations = 0;
  const ModelAnalysis a = analyze_model(resonance_model(), u, y, spec);
  EXPECT_GT(a.j_noncoherent_pct, 90.0);
  EXPECT_FALSE(a.history.has_value());
}

TEST(ModelAnalysis, HistoryFromJsonShapesAndErrors) {
  const nlohmann::json list = nlohmann::json::parse(R"([{"iter":0,"J_est_pct":10},{"iter":1,"J_est_pct":5,"J_val_pct":null,"mode":"pem"}])");
  for (const nlohmann::json& j : {list, nlohmann::json{{"history", list}}, nlohmann::json{{"meta", {{"history", list}}}}}) {
    const auto h = training_history_from_json(j, "h.json");
    ASSERT_TRUE(h.has_value());
    ASSERT_EQ(h->points.size(), 2u);
    EXPECT_EQ(h->points[1].j_est_pct, 5.0);
    EXPECT_EQ(h->points[1].mode, "pem");
    EXPECT_TRUE(std::isnan(h->points[1].j_val_pct));
  }
  EXPECT_FALSE(training_history_from_json(nlohmann::json::object(), "m.json").has_value());
  const std::string message = testing_support::one_line_error<ConfigError>([] {
    training_history_from_json(nlohmann::json::parse(R"({"history":[{"iter":0,"J_est_pct":"x"}]})"), "h.json");
  });
  EXPECT_NE(message.find("h.json: history[0].J_est_pct"), std::string::npos) << message;
}

TEST(ModelAnalysis, RefusesInitAsLongAsTheData) {
  const Eigen::VectorXd u = gaussian(1000, 1.0, 5);
  AnalysisSpec spec;
  spec.init = 1000;
  testing_support::expect_invalid([&] { analyze_model(resonance_model(), u, u, spec); }, "init");
}

}  // namespace
}  // namespace panelbass::models

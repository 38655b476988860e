// The oscillator model kind (models/oscillator): its band-limited input against a sampled sine, its RK4 run
// against the closed-form response of a linear oscillator and the energy a conservative Duffing oscillator
// keeps, its exact Jacobian against central differences, its initial-state fit, its fit recovering a known
// Duffing oscillator from noisy data, and its model file (round trip and named errors).

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "models/io/config_error.h"
#include "models/kinds/model_file.h"
#include "models/oscillator/oscillator_fit.h"
#include "models/oscillator/oscillator_model.h"
#include "models/validation/performance.h"
#include "tests/support/expect_error.h"
#include "tests/support/noise.h"

namespace panelbass {
namespace oscillator_test {

using models::BandLimitedInput;
using models::OscillatorRun;
using models::OscillatorSensitivity;
using models::OscillatorStructure;
using models::OscillatorTerm;

/// θ of structure `s` for a linear oscillator (d, k, g), everything else 0.
Eigen::VectorXd linear_theta(const OscillatorStructure& s, double d, double k, double g) {
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(s.parameter_count());
  theta(models::kOscDamping) = d;
  theta(models::kOscStiffness) = k;
  theta(models::kOscGain) = g;
  return theta;
}

TEST(BandLimitedInput, ASampledSineIsReconstructedBetweenItsSamples) {
  const double f = 0.1;  // cycles per sample, a fifth of Nyquist
  Eigen::VectorXd u(2000);
  for (Eigen::Index k = 0; k < u.size(); ++k) u(k) = std::sin(2 * std::numbers::pi * f * k);
  const BandLimitedInput input(u);
  for (double t = 900.0; t < 1100.0; t += 0.37) {  // away from the record's ends
    EXPECT_NEAR(input.value(t), std::sin(2 * std::numbers::pi * f * t), 1e-4) << t;
    EXPECT_NEAR(input.slope(t), 2 * std::numbers::pi * f * std::cos(2 * std::numbers::pi * f * t), 1e-3) << t;
  }
  EXPECT_EQ(input.slope(-3.0), 0.0) << "held before the record";
  EXPECT_EQ(input.value(5000.0), input.value(2000.0 - 1.0 / BandLimitedInput::kOversampling)) << "held after the grid";
}

TEST(OscillatorRun, ALinearOscillatorFollowsItsClosedFormResponse) {
  // ÿ + d·ẏ + k·y = g·u₀ from (y₀, v₀) with no input: y = y∞ + e^{−σt}(A·cos ω_d t + B·sin ω_d t) + the output offset.
  OscillatorStructure s;
  Eigen::VectorXd theta = linear_theta(s, 0.05, 0.04, 2.0);
  theta(models::kOscInputOffset) = 0.01;
  theta(models::kOscOutputOffset) = 0.1;
  const Eigen::Vector2d x0(0.2, -0.01);
  const OscillatorRun run = models::oscillator_run(s, theta, BandLimitedInput(Eigen::VectorXd::Zero(300)), x0,
                                                   OscillatorSensitivity::none);
  const double y_end = 2.0 * 0.01 / 0.04, sigma = 0.025, wd = std::sqrt(0.04 - sigma * sigma);
  const double A = x0(0) - y_end, B = (x0(1) + sigma * A) / wd;
  ASSERT_FALSE(run.diverged);
  for (Eigen::Index k = 0; k < 300; ++k) {
    const double t = static_cast<double>(k);
    const double expected = 0.1 + y_end + std::exp(-sigma * t) * (A * std::cos(wd * t) + B * std::sin(wd * t));
    EXPECT_NEAR(run.y(k), expected, 1e-7) << k;
  }
}

TEST(OscillatorRun, AConservativeDuffingOscillatorKeepsItsAmplitude) {
  // ÿ + k·y + c·y³ = 0 conserves v²/2 + k·y²/2 + c·y⁴/4: every turning point is back at y₀.
  OscillatorStructure s;
  s.terms = {OscillatorTerm::y3};
  Eigen::VectorXd theta = linear_theta(s, 0.0, 0.04, 0.0);
  theta(s.term_index(0)) = 0.02;
  s.substeps = 8;
  const OscillatorRun run = models::oscillator_run(s, theta, BandLimitedInput(Eigen::VectorXd::Zero(2300)),
                                                   Eigen::Vector2d(1.5, 0.0), OscillatorSensitivity::none);
  int peaks = 0;
  for (Eigen::Index k = 1; k + 1 < run.y.size(); ++k) {
    if (run.y(k) >= run.y(k - 1) && run.y(k) > run.y(k + 1)) {  // the parabola through three samples: its vertex
      const double a = 0.5 * (run.y(k - 1) + run.y(k + 1)) - run.y(k), b = 0.5 * (run.y(k + 1) - run.y(k - 1));
      EXPECT_NEAR(run.y(k) - b * b / (4 * a), 1.5, 2e-3) << "the peak near sample " << k;
      ++peaks;
    }
  }
  EXPECT_GT(peaks, 90) << "about 23 samples per cycle";
}

/// The largest relative difference between the columns of run(p)'s Jacobian and central differences of its
/// outputs (steps 1e-6·max(1, |p_j|)); p = [x(0); θ].
double jacobian_error(const OscillatorStructure& s, const Eigen::VectorXd& theta, const BandLimitedInput& input,
                      const Eigen::Vector2d& x0) {
  const OscillatorRun run = models::oscillator_run(s, theta, input, x0, OscillatorSensitivity::all);
  EXPECT_EQ(run.jacobian.cols(), 2 + theta.size());
  Eigen::VectorXd p(2 + theta.size());
  p << x0, theta;
  auto outputs = [&](const Eigen::VectorXd& q) {
    return models::oscillator_run(s, q.tail(theta.size()), input, q.head(2), OscillatorSensitivity::none).y;
  };
  double worst = 0.0;
  for (Eigen::Index j = 0; j < p.size(); ++j) {
    const double h = 1e-6 * std::max(1.0, std::abs(p(j)));
    Eigen::VectorXd plus = p, minus = p;
    plus(j) += h;
    minus(j) -= h;
    const Eigen::VectorXd difference = (outputs(plus) - outputs(minus)) / (2 * h);
    worst = std::max(worst, (run.jacobian.col(j) - difference).norm() / difference.norm());
  }
  return worst;
}

TEST(OscillatorRun, ItsJacobianEqualsCentralDifferences) {
  OscillatorStructure s;
  s.terms = {OscillatorTerm::y2, OscillatorTerm::y3, OscillatorTerm::y_abs_y, OscillatorTerm::y_v,
             OscillatorTerm::v2, OscillatorTerm::y_v2, OscillatorTerm::v_y2};
  s.substeps = 2;
  s.output_taps = 3;
  s.input_taps = 2;
  Eigen::VectorXd theta = linear_theta(s, 0.08, 0.05, 0.04);
  theta(models::kOscInputOffset) = 0.1;
  theta(models::kOscOutputOffset) = -0.2;
  theta(models::kOscDelay) = 0.3;
  const Eigen::VectorXd terms = testing_support::uniform_noise(7, 0.05, 7);
  for (std::size_t i = 0; i < s.terms.size(); ++i) theta(s.term_index(i)) = terms(static_cast<Eigen::Index>(i));
  theta.segment(s.output_tap_index(), 5) << 0.2, -0.1, 0.05, 0.3, -0.2;
  const BandLimitedInput input(testing_support::uniform_noise(400, 1.0, 3));
  EXPECT_LT(jacobian_error(s, theta, input, Eigen::Vector2d(0.4, -0.03)), 1e-6);
  const OscillatorRun all = models::oscillator_run(s, theta, input, Eigen::Vector2d(0.4, -0.03), OscillatorSensitivity::all);
  const OscillatorRun state_only =
      models::oscillator_run(s, theta, input, Eigen::Vector2d(0.4, -0.03), OscillatorSensitivity::initial_state);
  EXPECT_EQ((state_only.jacobian - all.jacobian.leftCols(2)).norm(), 0.0);
}

TEST(OscillatorRun, ItsJacobianOfTheLogDampingEqualsCentralDifferencesWhileTheVelocityStaysPositive) {
  // v·ln|v| curves as 1/v near v = 0, where a difference quotient's steps outrun it: a mass pushed by a
  // constant force against its damping and no spring keeps v > 0.
  OscillatorStructure s;
  s.terms = {OscillatorTerm::v_log_v};
  Eigen::VectorXd theta = linear_theta(s, 0.2, 0.0, 0.5);
  theta(models::kOscInputOffset) = 0.4;
  theta(s.term_index(0)) = 0.05;
  theta(models::kOscDelay) = 0.3;
  const BandLimitedInput input(testing_support::uniform_noise(300, 0.1, 4));
  EXPECT_LT(jacobian_error(s, theta, input, Eigen::Vector2d(0.0, 0.1)), 1e-6);
}

TEST(OscillatorInitialState, IsFoundFromTheFirstMeasuredOutputs) {
  OscillatorStructure s;
  s.terms = {OscillatorTerm::y3};
  Eigen::VectorXd theta = linear_theta(s, 0.03, 0.05, 0.05);
  theta(s.term_index(0)) = 0.1;
  const BandLimitedInput input(testing_support::uniform_noise(400, 1.0, 11));
  const Eigen::Vector2d x0(0.3, -0.05);
  const Eigen::VectorXd y = models::oscillator_run(s, theta, input, x0, OscillatorSensitivity::none).y;
  const Eigen::Vector2d found = models::oscillator_initial_state(s, theta, input, y, 50);
  EXPECT_NEAR(found(0), x0(0), 1e-7);
  EXPECT_NEAR(found(1), x0(1), 1e-7);
}

/// A raw record of the Duffing oscillator ÿ + d·ẏ + k·y + c·y³ = g·ũ(t − τ), with output noise.
struct DuffingRecord {
  Eigen::VectorXd u, y, clean;
};
DuffingRecord duffing_record(Eigen::Index n, std::uint64_t seed, double noise) {
  OscillatorStructure s;
  s.terms = {OscillatorTerm::y3};
  Eigen::VectorXd theta = linear_theta(s, 0.04, 0.03, 0.06);
  theta(s.term_index(0)) = 0.5;
  theta(models::kOscDelay) = 0.3;
  DuffingRecord r;
  r.u = testing_support::uniform_noise(n, 0.4, seed);
  r.clean = models::oscillator_run(s, theta, BandLimitedInput(r.u), Eigen::Vector2d::Zero(), OscillatorSensitivity::none).y;
  r.y = r.clean + testing_support::gaussian(n, noise, seed + 100);
  return r;
}

TEST(OscillatorFit, RecoversADuffingOscillatorFromNoisyData) {
  const DuffingRecord est = duffing_record(3000, 1, 1e-3), val = duffing_record(2000, 2, 1e-3);
  models::OscillatorFitOptions options;
  options.structure.terms = {OscillatorTerm::y3};
  const models::OscillatorFit fit = models::fit_oscillator(est.u, est.y, val.u, val.y, 100.0, options);
  ASSERT_EQ(fit.stages.size(), 2u);
  EXPECT_EQ(fit.best_stage, 1u);
  EXPECT_LT(fit.stages[1].j_val_pct, fit.stages[0].j_val_pct / 10) << "the cubic spring is what the linear model misses";
  // Back in raw units (y = s_y·y_s + m_y, u = s_u·u_s + m_u; time is in samples either way).
  const models::OscillatorModel& m = fit.model;
  const double sy = m.scaling.y_scale, su = m.scaling.u_scale;
  EXPECT_NEAR(m.theta(models::kOscDamping), 0.04, 0.04 * 0.02);
  EXPECT_NEAR(m.theta(models::kOscStiffness), 0.03, 0.03 * 0.02);
  EXPECT_NEAR(m.theta(models::kOscGain) * sy / su, 0.06, 0.06 * 0.02);
  EXPECT_NEAR(m.theta(models::kOscDelay), 0.3, 0.02);
  EXPECT_NEAR(m.theta(m.structure.term_index(0)) / (sy * sy), 0.5, 0.5 * 0.03);
  // Its validation J is at the noise floor: what the noise alone costs.
  const double floor = models::j_percent(val.clean, val.y, 50);
  EXPECT_LT(fit.stages[1].j_val_pct, 1.2 * floor);
  EXPECT_NEAR(models::j_percent(m.simulate(val.u, val.y, 50), val.y, 50), fit.stages[1].j_val_pct, 1e-12)
      << "the J chosen on is the J simulate gives";
}

/// A small oscillator model with every part set.
models::OscillatorModel small_model() {
  models::OscillatorModel m;
  m.structure.terms = {OscillatorTerm::y3, OscillatorTerm::v_log_v};
  m.structure.output_taps = 2;
  m.structure.input_taps = 1;
  m.theta = linear_theta(m.structure, 0.05, 0.04, 0.04);
  m.theta(m.structure.term_index(0)) = 0.1;
  m.theta(m.structure.term_index(1)) = 0.01;
  m.theta.tail(3) << 0.1, -0.05, 0.02;
  m.theta(models::kOscDelay) = 0.25;
  m.scaling = {0.1, 2.0, -0.3, 0.5};
  m.fs = 610.0;
  return m;
}

TEST(OscillatorModelFile, RoundTripsThroughJsonAndTheLoader) {
  const models::OscillatorModel m = small_model();
  const nlohmann::json j = models::oscillator_model_to_json(m);
  const models::AnyModel any = models::model_from_json(j);
  EXPECT_EQ(any.kind(), "oscillator");
  const auto& back = std::get<models::OscillatorModel>(any.model);
  EXPECT_EQ(back.theta, m.theta);
  EXPECT_EQ(back.structure.terms, m.structure.terms);
  const Eigen::VectorXd u = testing_support::uniform_noise(300, 1.0, 5);
  EXPECT_EQ(any.simulate(u), m.simulate(u));
}

TEST(OscillatorModelFile, BadFilesAreRefusedNamingTheKey) {
  const nlohmann::json good = models::oscillator_model_to_json(small_model());
  auto error_of = [](const nlohmann::json& j) {
    return testing_support::one_line_error<models::ConfigError>([&] { models::model_from_json(j); });
  };
  nlohmann::json j = good;
  j["params"]["terms"][1]["term"] = "v_cubed";
  EXPECT_NE(error_of(j).find("model.params.terms[1].term: unknown oscillator term \"v_cubed\""), std::string::npos) << error_of(j);
  j = good;
  j["params"]["substeps"] = 0;
  EXPECT_NE(error_of(j).find("model.params.substeps"), std::string::npos) << error_of(j);
  j = good;
  j["params"]["output_fir"][0] = "x";
  EXPECT_NE(error_of(j).find("model.params.output_fir[0]"), std::string::npos) << error_of(j);
  j = good;
  j["params"].erase("stiffness");
  EXPECT_NE(error_of(j).find("model.params.stiffness"), std::string::npos) << error_of(j);
  j = good;
  j["params"]["damping"] = -0.5;  // it gains energy: its free run leaves any bound
  EXPECT_NE(error_of(j).find("free run"), std::string::npos) << error_of(j);
  j = good;
  j["params"]["terms"].push_back({{"term", "y3"}, {"coefficient", 0.0}});
  EXPECT_NE(error_of(j).find("y3 is given twice"), std::string::npos) << error_of(j);
}

}  // namespace oscillator_test
}  // namespace panelbass

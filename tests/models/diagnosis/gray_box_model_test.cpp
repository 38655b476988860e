// The diagnosed model as a model file (kind "gray_box"): read back through the loader of every kind it simulates
// exactly as the diagnosis's model did (a saturation behind the drive's filter with its filters); a sensor offset
// term adds its constant (closed form); bad files are named.

#include <gtest/gtest.h>

#include <string>

#include "dsp/excitation.h"
#include "models/diagnosis/gray_box_model.h"
#include "models/io/config_error.h"
#include "models/kinds/model_file.h"

namespace panelbass::models {
namespace {

// A first-order linear part in scaled units (pole 0.5, one sample of delay) with a scaling that is not the identity.
GrayBoxModel first_order_gray_box() {
  GrayBoxModel m;
  m.fs = 1000.0;
  LinearModel& lin = m.augmented.linear;
  lin.fs = m.fs;
  lin.method = "oe";
  lin.tf.a = Eigen::VectorXd::Constant(1, -0.5);
  lin.tf.b = Eigen::VectorXd::Constant(1, 0.4);
  lin.tf.nk = 1;
  lin.scaling.u_scale = 2.0;
  lin.scaling.y_scale = 3.0;
  lin.scaling.y_offset = 0.1;
  m.augmented.lags = 2;
  m.augmented.state_mean << 0.01, -0.02, 0.03, 0.0;
  m.augmented.state_rms << 0.5, 0.7, 1.1, 1.3;
  return m;
}

TEST(GrayBoxModelFile, ReadBackItSimulatesAsWritten) {
  GrayBoxModel m = first_order_gray_box();
  DiagnosisTerm cubic;
  cubic.effect = Effect::cubic_stiffness;
  cubic.proxy = StateProxy::double_integral;
  cubic.coefficients = Eigen::VectorXd::LinSpaced(term_columns(cubic, m.augmented.lags), -0.03, 0.05);
  m.augmented.terms.push_back(cubic);
  // A saturation behind the drive's filter (a real pole at 0.3 of unit DC gain before it, the rest after it): its
  // filters are part of the file, or it would be read back as the drive's saturation as sampled.
  DiagnosisTerm clip;
  clip.effect = Effect::saturation;
  clip.proxy = StateProxy::input;
  clip.threshold = 0.9;
  clip.front.a = Eigen::VectorXd::Constant(1, -0.3);
  clip.front.b = Eigen::VectorXd::Constant(1, 0.7);
  clip.back.b = Eigen::VectorXd::Constant(1, 0.4);
  clip.back.nk = 1;
  clip.front_rms = 0.8;
  clip.coefficients = Eigen::VectorXd::LinSpaced(term_columns(clip, m.augmented.lags), 0.04, -0.02);
  m.augmented.terms.push_back(clip);
  DiagnosisTerm offset;
  offset.effect = Effect::dc_offset;
  offset.coefficients = Eigen::VectorXd::Constant(1, 0.02);
  m.augmented.terms.push_back(offset);
  const nlohmann::json file = gray_box_model_to_json(m);
  EXPECT_EQ(file["kind"], "gray_box");
  EXPECT_EQ(file["terms"][1]["front"]["a"], nlohmann::json::array({-0.3}));
  const AnyModel back = model_from_json(nlohmann::json::parse(file.dump()));
  EXPECT_EQ(back.kind(), "gray_box");
  EXPECT_EQ(back.fs(), 1000.0);
  const Eigen::VectorXd u = dsp::uniform_noise(3000, 1.0, 5);
  const Eigen::VectorXd y = dsp::uniform_noise(3000, 1.0, 6);
  const Eigen::VectorXd expected = simulate_augmented(m.augmented, u, y, 20);
  EXPECT_EQ((back.simulate(u, y, 20) - expected).cwiseAbs().maxCoeff(), 0.0);
  // The prediction: the linear part's one-step prediction plus what the terms add to the simulation from rest.
  const Eigen::VectorXd added = simulate_augmented(m.augmented, u, {}, 0) - m.augmented.linear.simulate(u);
  EXPECT_LT((back.predict(u, y) - (m.augmented.linear.predict(u, y) + added)).cwiseAbs().maxCoeff(), 1e-12);
}

// A sensor offset alone adds its coefficient times the output scale to the linear simulation (raw units).
TEST(GrayBoxModelFile, AnOffsetTermAddsItsConstant) {
  GrayBoxModel m = first_order_gray_box();
  DiagnosisTerm offset;
  offset.effect = Effect::dc_offset;
  offset.coefficients = Eigen::VectorXd::Constant(1, 0.02);
  m.augmented.terms.push_back(offset);
  const Eigen::VectorXd u = dsp::uniform_noise(500, 1.0, 7);
  const Eigen::VectorXd difference = m.simulate(u) - m.augmented.linear.simulate(u);
  EXPECT_NEAR(difference.minCoeff(), 0.02 * 3.0, 1e-12);
  EXPECT_NEAR(difference.maxCoeff(), 0.02 * 3.0, 1e-12);
}

std::string gray_box_error(const nlohmann::json& j) {
  try {
    model_from_json(j);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(GrayBoxModelFile, BadFilesAreNamed) {
  GrayBoxModel m = first_order_gray_box();
  DiagnosisTerm cubic;
  cubic.effect = Effect::cubic_stiffness;
  cubic.coefficients = Eigen::VectorXd::Zero(term_columns(cubic, m.augmented.lags));
  m.augmented.terms.push_back(cubic);
  const nlohmann::json good = gray_box_model_to_json(m);
  nlohmann::json bad = good;
  bad["terms"][0]["coefficients"].push_back(0.0);
  EXPECT_NE(gray_box_error(bad).find("model.terms[0].coefficients"), std::string::npos) << gray_box_error(bad);
  bad = good;
  bad["terms"][0]["effect"] = "warp_drive";
  EXPECT_NE(gray_box_error(bad).find("model.terms[0].effect"), std::string::npos) << gray_box_error(bad);
  bad = good;
  bad["linear"]["params"]["a"] = {-1.5};  // a pole at 1.5: unstable
  EXPECT_NE(gray_box_error(bad).find("model.linear"), std::string::npos) << gray_box_error(bad);
  bad = good;
  bad["state_rms"] = {1.0, 1.0, 1.0};
  EXPECT_NE(gray_box_error(bad).find("model.state_rms"), std::string::npos) << gray_box_error(bad);
  bad = good;
  bad["terms"][0]["front"] = {{"a", {-0.3}}, {"b", {0.7}}, {"nk", 0}};  // a filter before it and none after
  EXPECT_NE(gray_box_error(bad).find("\"front\" and \"back\" go together"), std::string::npos) << gray_box_error(bad);
  bad = good;
  bad["extra"] = 1;
  EXPECT_NE(gray_box_error(bad).find("extra"), std::string::npos) << gray_box_error(bad);
}

// A diagnosis of a simulation that is not linear has no model file: its terms need that simulation.
TEST(GrayBoxModelFile, ADiagnosisOfANonLinearBaselineIsRefused) {
  Diagnosis d;
  d.baseline_kind = "narx";
  d.model.simulate_baseline = [](const Eigen::VectorXd& u, const Eigen::VectorXd&, Eigen::Index) { return u; };
  EXPECT_THROW(gray_box_model_of(d), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

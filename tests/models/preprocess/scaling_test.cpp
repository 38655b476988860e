// Scaling (thesis ch. 3: |u_s|, |y_s| ≤ 1 and Σ u_s = Σ y_s = 0): hand values, the properties on
// random data, the inverse, the JSON round trip and every documented error.
#include "models/preprocess/scaling.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "dsp/excitation.h"
#include "models/io/config_error.h"
#include "tests/support/expect_error.h"
#include "tests/support/vectors.h"

namespace panelbass::models {
namespace {

using testing_support::vec;

// message_of<E>(f): the message of the exception `f` throws (std::invalid_argument or ConfigError), "" if none.
using testing_support::message_of;

TEST(ScalingTest, OffsetIsMeanAndScaleIsLargestDeviation) {
  // u: mean (1 + 2 + 3 + 6)/4 = 3, deviations −2, −1, 0, 3 → scale 3.
  // y: mean (−4 + 0 + 1 + 7)/4 = 1, deviations −5, −1, 0, 6 → scale 6.
  const Scaling s = scaling_from_data(vec({1.0, 2.0, 3.0, 6.0}), vec({-4.0, 0.0, 1.0, 7.0}));
  EXPECT_DOUBLE_EQ(s.u_offset, 3.0);
  EXPECT_DOUBLE_EQ(s.u_scale, 3.0);
  EXPECT_DOUBLE_EQ(s.y_offset, 1.0);
  EXPECT_DOUBLE_EQ(s.y_scale, 6.0);
}

TEST(ScalingTest, ScaledSignalsLieInUnitIntervalWithZeroMean) {
  const Eigen::VectorXd u = 3.7 * dsp::uniform_noise(5000, 1.0, 1).array() + 12.0;
  const Eigen::VectorXd y = 0.02 * dsp::gaussian_noise(5000, 1.0, 2).array() - 0.5;
  const Scaling s = scaling_from_data(u, y);
  const Eigen::VectorXd us = s.scale_u(u), ys = s.scale_y(y);
  EXPECT_LE(us.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_LE(ys.cwiseAbs().maxCoeff(), 1.0);
  // The sample that sets the scale lands exactly on ±1.
  EXPECT_EQ(us.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_EQ(ys.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_NEAR(us.mean(), 0.0, 1e-12);
  EXPECT_NEAR(ys.mean(), 0.0, 1e-12);
}

TEST(ScalingTest, UnscaleInvertsScale) {
  const Eigen::VectorXd u = dsp::uniform_noise(300, 2.0, 3);
  const Eigen::VectorXd y = 5.0 * dsp::uniform_noise(300, 1.0, 4).array() + 1.0;
  const Scaling s = scaling_from_data(u, y);
  EXPECT_LT((s.unscale_y(s.scale_y(y)) - y).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(ScalingTest, RejectsConstantSignals) {
  const Eigen::VectorXd varying = vec({0.0, 1.0, 2.0});
  const Eigen::VectorXd constant = vec({0.5, 0.5, 0.5});
  EXPECT_NE(message_of<std::invalid_argument>([&] { scaling_from_data(constant, varying); }).find("input is constant"),
            std::string::npos);
  EXPECT_NE(message_of<std::invalid_argument>([&] { scaling_from_data(varying, constant); }).find("output is constant"),
            std::string::npos);
}

TEST(ScalingTest, RejectsNonFiniteSignals) {
  Eigen::VectorXd bad = vec({0.0, 1.0, 2.0});
  bad[1] = std::numeric_limits<double>::quiet_NaN();
  const Eigen::VectorXd good = vec({0.0, 1.0, 2.0});
  EXPECT_NE(message_of<std::invalid_argument>([&] { scaling_from_data(bad, good); }).find("input is not finite"),
            std::string::npos);
  bad[1] = std::numeric_limits<double>::infinity();
  EXPECT_NE(message_of<std::invalid_argument>([&] { scaling_from_data(good, bad); }).find("output is not finite"),
            std::string::npos);
}

TEST(ScalingTest, RejectsEmptySignals) {
  EXPECT_THROW(scaling_from_data(Eigen::VectorXd(0), vec({0.0, 1.0})), std::invalid_argument);
}

TEST(ScalingTest, JsonRoundTripIsExact) {
  Scaling s;
  s.u_offset = 0.1234567890123456789;
  s.u_scale = 3.0 / 7.0;
  s.y_offset = -1e-300;
  s.y_scale = 12345.678901234567;
  const nlohmann::json j = scaling_to_json(s);
  EXPECT_EQ(j.size(), 4u);
  // Through text, as a model file stores it.
  const Scaling back = scaling_from_json(nlohmann::json::parse(j.dump()), "model.scaling");
  EXPECT_EQ(back.u_offset, s.u_offset);
  EXPECT_EQ(back.u_scale, s.u_scale);
  EXPECT_EQ(back.y_offset, s.y_offset);
  EXPECT_EQ(back.y_scale, s.y_scale);
}

nlohmann::json valid_scaling_json() {
  return {{"u_offset", 0.0}, {"u_scale", 1.0}, {"y_offset", 0.5}, {"y_scale", 2.0}};
}

std::string json_error(const nlohmann::json& j) {
  return message_of<ConfigError>([&] { scaling_from_json(j, "model.scaling"); });
}

TEST(ScalingTest, JsonRejectsMissingKey) {
  nlohmann::json j = valid_scaling_json();
  j.erase("y_offset");
  EXPECT_EQ(json_error(j), "model.scaling.y_offset: missing");
}

TEST(ScalingTest, JsonRejectsNonPositiveScale) {
  nlohmann::json j = valid_scaling_json();
  j["u_scale"] = 0.0;
  EXPECT_EQ(json_error(j), "model.scaling.u_scale: must be > 0, got 0");
  j = valid_scaling_json();
  j["y_scale"] = -2.0;
  EXPECT_EQ(json_error(j), "model.scaling.y_scale: must be > 0, got -2");
}

TEST(ScalingTest, JsonRejectsNonNumberAndNonFinite) {
  nlohmann::json j = valid_scaling_json();
  j["u_offset"] = "zero";
  EXPECT_EQ(json_error(j), "model.scaling.u_offset: expected a number, got string");
  j = valid_scaling_json();
  j["y_offset"] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(json_error(j), "model.scaling.y_offset: not finite");
}

TEST(ScalingTest, JsonRejectsUnknownKeyAndNonObject) {
  nlohmann::json j = valid_scaling_json();
  j["gain"] = 1.0;
  EXPECT_EQ(json_error(j), "model.scaling.gain: unknown key");
  EXPECT_NE(json_error(nlohmann::json::array()).find("model.scaling: expected an object"), std::string::npos);
}

}  // namespace
}  // namespace panelbass::models

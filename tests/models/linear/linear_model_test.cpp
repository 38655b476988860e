// LinearModel: simulation in raw units against a plain difference equation, initialisation from
// measured outputs, one-step prediction against a hand-written ARX predictor, and the model file
// (round trip, save/load, one test per validation failure).
#include "models/linear/linear_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unistd.h>

#include "dsp/excitation.h"
#include "models/io/config_error.h"
#include "tests/support/expect_error.h"
#include "tests/support/vectors.h"

namespace panelbass::models {
namespace {

using testing_support::vec;

using testing_support::message_of;

// A 4th-order model with delay and a non-trivial scaling, as an identification would store it.
LinearModel example_model() {
  LinearModel m;
  Eigen::VectorXcd poles(4);
  poles << std::polar(0.95, 0.2), std::polar(0.95, -0.2), std::polar(0.8, 1.0), std::polar(0.8, -1.0);
  const Eigen::VectorXd a = polynomial_from_roots(poles);
  m.tf.a = a.tail(4);
  m.tf.b = vec({0.3, -0.1, 0.2});
  m.tf.nk = 2;
  m.fs = 3000.0;
  m.scaling.u_offset = 0.25;
  m.scaling.u_scale = 2.0;
  m.scaling.y_offset = -1.5;
  m.scaling.y_scale = 0.04;
  m.method = "arx";
  m.meta = {{"data", "sweep.wav"}, {"J_percent", 3.2}, {"orders", {4, 3, 2}}};
  return m;
}

// The difference equation in scaled units, with output history y(−1), y(−2), … = `past` (most recent
// first) and input at rest before the record: ys(k) = −Σ a_i·ys(k−i) + Σ b_j·us(k−nk−j).
Eigen::VectorXd difference_equation(const TransferFunction& tf, const Eigen::VectorXd& us,
                                    const Eigen::VectorXd& past = {}) {
  Eigen::VectorXd ys(us.size());
  for (Eigen::Index k = 0; k < us.size(); ++k) {
    double v = 0.0;
    for (Eigen::Index i = 1; i <= tf.na(); ++i) {
      if (k - i >= 0) {
        v -= tf.a[i - 1] * ys[k - i];
      } else if (i - k - 1 < past.size()) {
        v -= tf.a[i - 1] * past[i - k - 1];
      }
    }
    for (Eigen::Index j = 0; j < tf.nb(); ++j) {
      if (k - tf.nk - j >= 0) v += tf.b[j] * us[k - tf.nk - j];
    }
    ys[k] = v;
  }
  return ys;
}

TEST(LinearModelTest, SimulateMapsRawUnitsThroughScaledModel) {
  const LinearModel m = example_model();
  const Eigen::VectorXd u = 3.0 * dsp::uniform_noise(1500, 1.0, 1).array() + 0.7;
  // ŷ_raw = y_scale·H(q)·((u − u_offset)/u_scale) + y_offset, the recursion written out.
  const Eigen::VectorXd us = (u.array() - 0.25) / 2.0;
  const Eigen::VectorXd expected = 0.04 * difference_equation(m.tf, us).array() - 1.5;
  EXPECT_LT((m.simulate(u) - expected).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(LinearModelTest, InitialisedSimulationBeatsZeroStateOnDataWithHistory) {
  // Data from the same system, but with output history before the record (a nonzero initial state
  // that the model's state coordinates know nothing about).
  const LinearModel m = example_model();
  const Eigen::VectorXd u = dsp::uniform_noise(400, 1.0, 2);
  const Eigen::VectorXd us = (u.array() - 0.25) / 2.0;
  const Eigen::VectorXd ys = difference_equation(m.tf, us, vec({4.0, 3.0, -2.0, 1.0}));
  const Eigen::VectorXd y = 0.04 * ys.array() - 1.5;

  const Eigen::VectorXd from_rest = m.simulate(u);
  const Eigen::VectorXd initialised = m.simulate(u, y, 50);
  const double rest_error = (from_rest.head(50) - y.head(50)).norm();
  const double init_error = (initialised.head(50) - y.head(50)).norm();
  EXPECT_GT(rest_error, 0.1);      // the history is far from negligible …
  EXPECT_LT(init_error, 1e-9);     // … and the exact model explains it completely
  EXPECT_LT((initialised - y).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(LinearModelTest, SimulateValidatesArguments) {
  const LinearModel m = example_model();
  const Eigen::VectorXd u = dsp::uniform_noise(100, 1.0, 3);
  EXPECT_THROW(m.simulate(u, Eigen::VectorXd::Zero(99), 10), std::invalid_argument);  // lengths differ
  EXPECT_THROW(m.simulate(u, Eigen::VectorXd::Zero(100), 101), std::invalid_argument);  // > N
  EXPECT_THROW(m.simulate(u, Eigen::VectorXd::Zero(100), -1), std::invalid_argument);
  EXPECT_THROW(m.simulate(u, Eigen::VectorXd(), 10), std::invalid_argument);  // no y to start from
  EXPECT_THROW(m.simulate(u, Eigen::VectorXd::Zero(100), 3), std::invalid_argument);  // < 6 states
  Eigen::VectorXd bad = u;
  bad[7] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(m.simulate(bad), std::invalid_argument);
  EXPECT_THROW(m.simulate(u, bad, 20), std::invalid_argument);
}

TEST(LinearModelTest, PredictEqualsHandWrittenArxPredictor) {
  const LinearModel m = example_model();
  const Eigen::VectorXd u = dsp::uniform_noise(300, 1.0, 4);
  const Eigen::VectorXd y = 0.05 * dsp::uniform_noise(300, 1.0, 5).array() - 1.5;  // any measured y
  const Eigen::VectorXd prediction = m.predict(u, y);
  // First max(na, nk + nb − 1) = max(4, 4) = 4 samples are returned as measured.
  for (Eigen::Index k = 0; k < 4; ++k) EXPECT_DOUBLE_EQ(prediction[k], y[k]);
  for (Eigen::Index k = 4; k < u.size(); ++k) {
    // ŷs(k) = −a1·ys(k−1) − … − a4·ys(k−4) + b0·us(k−2) + b1·us(k−3) + b2·us(k−4)
    auto us = [&](Eigen::Index t) { return (u[t] - 0.25) / 2.0; };
    auto ys = [&](Eigen::Index t) { return (y[t] + 1.5) / 0.04; };
    const double scaled = -m.tf.a[0] * ys(k - 1) - m.tf.a[1] * ys(k - 2) - m.tf.a[2] * ys(k - 3) -
                          m.tf.a[3] * ys(k - 4) + 0.3 * us(k - 2) - 0.1 * us(k - 3) + 0.2 * us(k - 4);
    ASSERT_NEAR(prediction[k], 0.04 * scaled - 1.5, 1e-12) << "k = " << k;
  }
}

TEST(LinearModelTest, PredictionOfNoiselessDataIsExact) {
  const LinearModel m = example_model();
  const Eigen::VectorXd u = dsp::uniform_noise(300, 1.0, 6);
  const Eigen::VectorXd y = m.simulate(u);
  EXPECT_LT((m.predict(u, y) - y).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(LinearModelTest, PredictValidatesArguments) {
  const LinearModel m = example_model();
  EXPECT_THROW(m.predict(Eigen::VectorXd::Zero(10), Eigen::VectorXd::Zero(9)), std::invalid_argument);
  Eigen::VectorXd bad = Eigen::VectorXd::Zero(10);
  bad[3] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(m.predict(bad, Eigen::VectorXd::Zero(10)), std::invalid_argument);
  EXPECT_THROW(m.predict(Eigen::VectorXd::Zero(10), bad), std::invalid_argument);
}

void expect_same_model(const LinearModel& got, const LinearModel& want) {
  EXPECT_EQ(got.tf.a, want.tf.a);
  EXPECT_EQ(got.tf.b, want.tf.b);
  EXPECT_EQ(got.tf.nk, want.tf.nk);
  EXPECT_EQ(got.fs, want.fs);
  EXPECT_EQ(got.scaling.u_offset, want.scaling.u_offset);
  EXPECT_EQ(got.scaling.u_scale, want.scaling.u_scale);
  EXPECT_EQ(got.scaling.y_offset, want.scaling.y_offset);
  EXPECT_EQ(got.scaling.y_scale, want.scaling.y_scale);
  EXPECT_EQ(got.method, want.method);
  EXPECT_EQ(got.meta, want.meta);
}

TEST(LinearModelTest, JsonRoundTripIsExact) {
  const LinearModel m = example_model();
  const nlohmann::json j = linear_model_to_json(m);
  EXPECT_EQ(j.at("format"), "panelbass.model/1");
  EXPECT_EQ(j.at("kind"), "linear");
  EXPECT_EQ(j.at("method"), "arx");
  EXPECT_EQ(j.at("params").at("nk"), 2);
  expect_same_model(linear_model_from_json(nlohmann::json::parse(j.dump())), m);
}

TEST(LinearModelTest, SaveLoadRoundTrip) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("linear_model_test_" + std::to_string(::getpid()) + ".json");
  const LinearModel m = example_model();
  save_linear_model(path, m);
  expect_same_model(load_linear_model(path), m);
  std::filesystem::remove(path);
}

TEST(LinearModelTest, LoadErrorsStartWithFileName) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path();
  const std::filesystem::path missing = dir / "linear_model_test_no_such_file.json";
  EXPECT_EQ(message_of<ConfigError>([&] { load_linear_model(missing); }).rfind(missing.string() + ": ", 0), 0u);

  const std::filesystem::path bad = dir / ("linear_model_test_bad_" + std::to_string(::getpid()) + ".json");
  {
    std::ofstream out(bad);
    out << "{\"format\": ";
  }
  EXPECT_EQ(message_of<ConfigError>([&] { load_linear_model(bad); }).rfind(bad.string() + ": not valid JSON", 0), 0u);
  {
    nlohmann::json j = linear_model_to_json(example_model());
    j["fs"] = -1.0;
    std::ofstream out(bad);
    out << j.dump();
  }
  EXPECT_EQ(message_of<ConfigError>([&] { load_linear_model(bad); }), bad.string() + ": model.fs: must be > 0, got -1");
  std::filesystem::remove(bad);
}

TEST(LinearModelTest, SaveToUnwritablePathNamesIt) {
  const std::filesystem::path path = "/nonexistent_dir_for_linear_model_test/model.json";
  EXPECT_EQ(message_of<ConfigError>([&] { save_linear_model(path, example_model()); }).rfind(path.string(), 0), 0u);
}

// The error linear_model_from_json gives for the example model's JSON after `edit`.
template <typename Edit>
std::string error_after(Edit edit) {
  nlohmann::json j = linear_model_to_json(example_model());
  edit(j);
  return message_of<ConfigError>([&] { linear_model_from_json(j); });
}

TEST(LinearModelTest, RejectsMissingFormat) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j.erase("format"); }), "model.format: missing");
}

TEST(LinearModelTest, RejectsWrongFormat) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["format"] = "panelbass.model/2"; }),
            "model.format: expected \"panelbass.model/1\", got \"panelbass.model/2\"");
}

TEST(LinearModelTest, RejectsWrongKind) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["kind"] = "narx"; }), "model.kind: expected \"linear\", got \"narx\"");
}

TEST(LinearModelTest, RejectsNonPositiveFs) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["fs"] = 0.0; }), "model.fs: must be > 0, got 0");
}

TEST(LinearModelTest, RejectsNonNumericFs) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["fs"] = "3000"; }), "model.fs: expected a number, got string");
}

TEST(LinearModelTest, RejectsNonFiniteFs) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["fs"] = std::numeric_limits<double>::infinity(); }),
            "model.fs: not finite");
}

TEST(LinearModelTest, RejectsMissingScaling) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j.erase("scaling"); }), "model.scaling: missing");
}

TEST(LinearModelTest, RejectsInvalidScaling) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["scaling"]["y_scale"] = -0.5; }),
            "model.scaling.y_scale: must be > 0, got -0.5");
}

TEST(LinearModelTest, RejectsMissingParams) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j.erase("params"); }), "model.params: missing");
}

TEST(LinearModelTest, RejectsNonFiniteCoefficientNamingIndex) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["params"]["a"][3] = std::numeric_limits<double>::quiet_NaN(); }),
            "model.params.a[3]: not finite");
}

TEST(LinearModelTest, RejectsNonNumericCoefficientNamingIndex) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["params"]["b"][1] = nullptr; }),
            "model.params.b[1]: expected a number, got null");
}

TEST(LinearModelTest, RejectsCoefficientsThatAreNotAnArray) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["params"]["a"] = 0.5; }),
            "model.params.a: expected an array of numbers, got number");
}

TEST(LinearModelTest, RejectsMissingDenominator) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["params"].erase("a"); }), "model.params.a: missing");
}

TEST(LinearModelTest, RejectsEmptyNumerator) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["params"]["b"] = nlohmann::json::array(); }),
            "model.params.b: must not be empty");
}

TEST(LinearModelTest, RejectsNegativeDelay) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["params"]["nk"] = -1; }).rfind("model.params.nk: must be within [0, ", 0),
            0u);
}

TEST(LinearModelTest, RejectsFractionalDelay) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["params"]["nk"] = 1.5; }),
            "model.params.nk: expected an integer, got number");
}

TEST(LinearModelTest, RejectsUnknownTopLevelKey) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["gain"] = 2.0; }), "model.gain: unknown key");
}

TEST(LinearModelTest, RejectsUnknownParamsKey) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["params"]["c"] = nlohmann::json::array({1.0}); }),
            "model.params.c: unknown key");
}

TEST(LinearModelTest, RejectsMetaThatIsNotAnObject) {
  EXPECT_EQ(error_after([](nlohmann::json& j) { j["meta"] = "notes"; }), "model.meta: expected an object, got string");
}

TEST(LinearModelTest, RejectsNonObject) {
  EXPECT_EQ(message_of<ConfigError>([] { linear_model_from_json(nlohmann::json::array()); }),
            "model: expected an object, got array");
}

TEST(LinearModelTest, RejectsUnstableModelNamingPole) {
  // Poles 1.02·e^{±j2π·150/3000}: radius 1.02 at 150 Hz, plus a stable pair.
  const double omega = 2.0 * std::numbers::pi * 150.0 / 3000.0;
  Eigen::VectorXcd poles(4);
  poles << std::polar(1.02, omega), std::polar(1.02, -omega), std::polar(0.5, 2.0), std::polar(0.5, -2.0);
  const Eigen::VectorXd a = polynomial_from_roots(poles);
  EXPECT_EQ(error_after([&](nlohmann::json& j) {
              j["params"]["a"] = std::vector<double>(a.data() + 1, a.data() + a.size());
            }),
            "model: unstable, pole of radius 1.02 at 150 Hz");
}

TEST(LinearModelTest, AcceptsFirAndOptionalKeys) {
  // An FIR (a = []) without nk, method or meta: nk = 0, method "", meta {}.
  const nlohmann::json j = {{"format", "panelbass.model/1"},
                            {"kind", "linear"},
                            {"fs", 48000},
                            {"scaling", {{"u_offset", 0}, {"u_scale", 1}, {"y_offset", 0}, {"y_scale", 1}}},
                            {"params", {{"a", nlohmann::json::array()}, {"b", {0.5, 0.25}}}}};
  const LinearModel m = linear_model_from_json(j);
  EXPECT_EQ(m.tf.na(), 0);
  EXPECT_EQ(m.tf.nb(), 2);
  EXPECT_EQ(m.tf.nk, 0);
  EXPECT_EQ(m.fs, 48000.0);
  EXPECT_EQ(m.method, "");
  EXPECT_EQ(m.meta, nlohmann::json::object());
}

}  // namespace
}  // namespace panelbass::models

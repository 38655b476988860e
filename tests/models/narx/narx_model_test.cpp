// The neural NARX model ([5G], [5H]) against hand-written loops: the regressor layout, parallel
// simulation and series-parallel prediction, the measured initial outputs, raw-unit scaling checked
// against a network that is linear to 1e-8, and the model file (round trip, every failure mode).
#include "models/narx/narx_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "models/io/config_error.h"
#include "tests/support/narx_models.h"
#include "tests/support/vectors.h"

namespace panelbass::models {
namespace {

using testing_support::vec;

// A deterministic, non-periodic test signal in [−amplitude, amplitude].
Eigen::VectorXd signal(Eigen::Index n, double amplitude, double phase) {
  Eigen::VectorXd x(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    x[k] = amplitude * (0.6 * std::sin(0.31 * k + phase) + 0.4 * std::cos(0.047 * k * k + 2.0 * phase));
  }
  return x;
}

// F(x) for one hidden tanh layer, written out over θ's layout (W row by row, b, v, c).
double plain_net(const Eigen::VectorXd& theta, int inputs, int width, const std::vector<double>& x) {
  double y = theta[static_cast<Eigen::Index>(width) * (inputs + 1) + width];
  for (int i = 0; i < width; ++i) {
    double s = theta[static_cast<Eigen::Index>(width) * inputs + i];
    for (int j = 0; j < inputs; ++j) s += theta[static_cast<Eigen::Index>(i) * inputs + j] * x[static_cast<std::size_t>(j)];
    y += theta[static_cast<Eigen::Index>(width) * (inputs + 1) + i] * std::tanh(s);
  }
  return y;
}

// [5G] by hand: x = [p(k−1)..p(k−na), u(k−nk)..u(k−nk−nb)], zero before the record.
std::vector<double> plain_regressor(const NarxStructure& s, const Eigen::VectorXd& u, const Eigen::VectorXd& past,
                                    Eigen::Index k) {
  std::vector<double> x;
  for (int i = 1; i <= s.na; ++i) x.push_back(k - i >= 0 ? past[k - i] : 0.0);
  for (int j = 0; j <= s.nb; ++j) x.push_back(k - s.nk - j >= 0 ? u[k - s.nk - j] : 0.0);
  return x;
}

NarxModel small_model(std::uint64_t seed = 3) {
  NarxStructure s;
  s.na = 2;
  s.nb = 1;
  s.nk = 1;
  s.hidden = {3};
  NarxModel m = NarxModel::with_structure(s, Scaling{}, 48000.0);
  m.net.initialize(1.0, seed, 2.0);
  return m;
}

// Runs `f` and expects `Error` whose message contains `needle`.
template <class Error, class F>
void expect_error(F f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "no exception; expected one containing \"" << needle << "\"";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << "message: " << e.what();
  }
}

TEST(NarxModel, WithStructureSizesTheNetwork) {
  const NarxModel m = small_model();
  EXPECT_EQ(m.structure.inputs(), 4);
  EXPECT_EQ(m.net.inputs(), 4);
  EXPECT_EQ(m.net.hidden(), std::vector<int>{3});
  EXPECT_EQ(m.net.parameter_count(), 3 * 4 + 3 + 3 + 1);
  EXPECT_EQ(m.fs, 48000.0);
  NarxStructure bad;
  bad.na = -1;
  expect_error<std::invalid_argument>([&] { NarxModel::with_structure(bad, Scaling{}, 1.0); }, "na");
}

TEST(NarxModel, RegressorLayout) {
  NarxStructure s;
  s.na = 2;
  s.nb = 2;
  s.nk = 1;
  s.hidden = {2};
  const NarxModel m = NarxModel::with_structure(s, Scaling{}, 1.0);
  const Eigen::VectorXd u = vec({10, 11, 12, 13, 14});
  const Eigen::VectorXd y = vec({20, 21, 22, 23, 24});
  Eigen::VectorXd x(5);
  // k = 3: [y(2) y(1) | u(2) u(1) u(0)]
  m.regressor(u, y, 3, x);
  EXPECT_EQ(x, vec({22, 21, 12, 11, 10}));
  // k = 1: [y(0) 0 | u(0) 0 0]: before the record counts as 0
  m.regressor(u, y, 1, x);
  EXPECT_EQ(x, vec({20, 0, 10, 0, 0}));
  // k = 0: nothing is known yet
  m.regressor(u, y, 0, x);
  EXPECT_EQ(x, vec({0, 0, 0, 0, 0}));
  // k = 4: [y(3) y(2) | u(3) u(2) u(1)]
  m.regressor(u, y, 4, x);
  EXPECT_EQ(x, vec({23, 22, 13, 12, 11}));
}

TEST(NarxModel, RegressorWithoutPastOutputsOrDelay) {
  NarxStructure s;
  s.na = 0;
  s.nb = 1;
  s.nk = 0;
  s.hidden = {1};
  const NarxModel m = NarxModel::with_structure(s, Scaling{}, 1.0);
  Eigen::VectorXd x(2);
  m.regressor(vec({1, 2, 3}), vec({7, 8, 9}), 2, x);
  EXPECT_EQ(x, vec({3, 2}));
}

TEST(NarxModel, SimulateScaledEqualsHandLoop) {
  const NarxModel m = small_model();
  const Eigen::Index n = 200;
  const Eigen::VectorXd u = signal(n, 1.0, 0.2);
  const Eigen::VectorXd sim = m.simulate_scaled(u);
  // [5H] OEM: the simulated output is the past
  Eigen::VectorXd expected(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    expected[k] = plain_net(m.net.parameters(), 4, 3, plain_regressor(m.structure, u, expected, k));
  }
  ASSERT_EQ(sim.size(), n);
  for (Eigen::Index k = 0; k < n; ++k) EXPECT_NEAR(sim[k], expected[k], 1e-12) << "k = " << k;
}

TEST(NarxModel, PredictScaledUsesMeasuredOutputs) {
  const NarxModel m = small_model(4);
  const Eigen::Index n = 150;
  const Eigen::VectorXd u = signal(n, 1.0, 0.5);
  const Eigen::VectorXd y = signal(n, 0.8, 1.7);
  const Eigen::VectorXd pred = m.predict_scaled(u, y);
  ASSERT_EQ(pred.size(), n);
  // [5H] PEM: the measured output is the past
  for (Eigen::Index k = 0; k < n; ++k) {
    EXPECT_NEAR(pred[k], plain_net(m.net.parameters(), 4, 3, plain_regressor(m.structure, u, y, k)), 1e-12)
        << "k = " << k;
  }
  // Not the simulation: the past differs.
  EXPECT_GT((pred - m.simulate_scaled(u)).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(NarxModel, InitialOutputsAreTheMeasured) {
  const NarxModel m = small_model(5);
  const Eigen::Index n = 60, init = 7;
  const Eigen::VectorXd u = signal(n, 1.0, 0.9);
  const Eigen::VectorXd y = signal(n, 0.5, 2.3);
  const Eigen::VectorXd sim = m.simulate_scaled(u, y, init);
  for (Eigen::Index k = 0; k < init; ++k) EXPECT_EQ(sim[k], y[k]) << "k = " << k;
  Eigen::VectorXd expected = y;
  for (Eigen::Index k = init; k < n; ++k) {
    expected[k] = plain_net(m.net.parameters(), 4, 3, plain_regressor(m.structure, u, expected, k));
  }
  for (Eigen::Index k = init; k < n; ++k) EXPECT_NEAR(sim[k], expected[k], 1e-12) << "k = " << k;
  // init = 0 with y given ignores y.
  EXPECT_EQ(m.simulate_scaled(u, y, 0), m.simulate_scaled(u));
}

// ŷ(k) ≈ 0.5·ŷ(k−1) + 0.3·u(k) + 0.1 in scaled units: each path goes through a node with weight ε and
// back out with weight c/ε, so tanh(εx)·c/ε = c·x·(1 − (εx)²/3 + …) is linear to ~1e-9.
NarxModel linear_model(const Scaling& scaling) {
  NarxStructure s;
  s.na = 1;
  s.nb = 0;
  s.nk = 0;
  s.hidden = {2};
  NarxModel m = NarxModel::with_structure(s, scaling, 8000.0);
  const double eps = 1e-4;
  // W = [[ε, 0], [0, ε]], b = [0, 0], v = [0.5/ε, 0.3/ε], c = 0.1
  m.net.parameters() << eps, 0.0, 0.0, eps, 0.0, 0.0, 0.5 / eps, 0.3 / eps, 0.1;
  return m;
}

TEST(NarxModel, SimulateOnRawDataAppliesScaling) {
  Scaling scaling;
  scaling.u_offset = 2.0;
  scaling.u_scale = 4.0;
  scaling.y_offset = -3.0;
  scaling.y_scale = 0.25;
  const NarxModel m = linear_model(scaling);
  const Eigen::Index n = 300;
  const Eigen::VectorXd u = signal(n, 4.0, 0.1).array() + 2.0;  // raw: 2 ± 4
  // By hand, in raw units: scale u, run the linear recursion, unscale.
  Eigen::VectorXd expected(n);
  double prev = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    const double s = 0.5 * prev + 0.3 * (u[k] - 2.0) / 4.0 + 0.1;
    expected[k] = -3.0 + 0.25 * s;
    prev = s;
  }
  const Eigen::VectorXd sim = m.simulate(u);
  ASSERT_EQ(sim.size(), n);
  for (Eigen::Index k = 0; k < n; ++k) EXPECT_NEAR(sim[k], expected[k], 1e-8) << "k = " << k;

  // With init: the first samples are the measured (raw) ones, and the recursion starts from them.
  const Eigen::VectorXd y = expected.array() + 0.01;
  const Eigen::Index init = 5;
  const Eigen::VectorXd seeded = m.simulate(u, y, init);
  for (Eigen::Index k = 0; k < init; ++k) EXPECT_NEAR(seeded[k], y[k], 1e-14) << "k = " << k;
  prev = (y[init - 1] + 3.0) / 0.25;
  for (Eigen::Index k = init; k < n; ++k) {
    const double s = 0.5 * prev + 0.3 * (u[k] - 2.0) / 4.0 + 0.1;
    EXPECT_NEAR(seeded[k], -3.0 + 0.25 * s, 1e-8) << "k = " << k;
    prev = s;
  }
}

TEST(NarxModel, PredictOnRawDataAppliesScaling) {
  Scaling scaling;
  scaling.u_offset = -1.0;
  scaling.u_scale = 2.0;
  scaling.y_offset = 5.0;
  scaling.y_scale = 3.0;
  const NarxModel m = linear_model(scaling);
  const Eigen::Index n = 100;
  const Eigen::VectorXd u = signal(n, 2.0, 0.4).array() - 1.0;
  const Eigen::VectorXd y = signal(n, 3.0, 1.1).array() + 5.0;
  const Eigen::VectorXd pred = m.predict(u, y);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double y_prev = k > 0 ? (y[k - 1] - 5.0) / 3.0 : 0.0;
    const double s = 0.5 * y_prev + 0.3 * (u[k] + 1.0) / 2.0 + 0.1;
    EXPECT_NEAR(pred[k], 5.0 + 3.0 * s, 1e-8) << "k = " << k;
  }
}

TEST(NarxModel, SimulationArgumentsAreValidated) {
  const NarxModel m = small_model();
  const Eigen::VectorXd u = signal(20, 1.0, 0.0);
  const Eigen::VectorXd y = signal(20, 1.0, 1.0);
  expect_error<std::invalid_argument>([&] { m.simulate_scaled(u, signal(19, 1.0, 0.0)); }, "y has 19 samples, u has 20");
  expect_error<std::invalid_argument>([&] { m.simulate_scaled(u, y, 21); }, "init = 21");
  expect_error<std::invalid_argument>([&] { m.simulate_scaled(u, y, -1); }, "init = -1");
  expect_error<std::invalid_argument>([&] { m.simulate_scaled(u, Eigen::VectorXd(), 3); }, "needs the measured output");
  Eigen::VectorXd bad_u = u;
  bad_u[4] = std::numeric_limits<double>::quiet_NaN();
  expect_error<std::invalid_argument>([&] { m.simulate_scaled(bad_u); }, "u is not finite (sample 4)");
  expect_error<std::invalid_argument>([&] { m.simulate(bad_u); }, "u is not finite (sample 4)");
  Eigen::VectorXd bad_y = y;
  bad_y[2] = std::numeric_limits<double>::infinity();
  expect_error<std::invalid_argument>([&] { m.simulate_scaled(u, bad_y, 5); }, "y is not finite (sample 2)");
  expect_error<std::invalid_argument>([&] { m.simulate(u, bad_y, 5); }, "y is not finite (sample 2)");
  // A non-finite y past the initial samples is never read.
  EXPECT_NO_THROW(m.simulate_scaled(u, bad_y, 2));
  expect_error<std::invalid_argument>([&] { m.predict_scaled(u, signal(21, 1.0, 0.0)); }, "y has 21 samples, u has 20");
  expect_error<std::invalid_argument>([&] { m.predict_scaled(u, bad_y); }, "y is not finite (sample 2)");
  expect_error<std::invalid_argument>([&] { m.predict(bad_u, y); }, "u is not finite (sample 4)");
  expect_error<std::invalid_argument>([&] { m.predict(u, signal(3, 1.0, 0.0)); }, "y has 3 samples");
  NarxModel mismatched = m;
  mismatched.structure.na = 5;
  expect_error<std::invalid_argument>([&] { mismatched.simulate_scaled(u); }, "network");
}

TEST(NarxModel, EmptyRecordGivesEmptyOutput) {
  const NarxModel m = small_model();
  EXPECT_EQ(m.simulate_scaled(Eigen::VectorXd()).size(), 0);
  EXPECT_EQ(m.predict_scaled(Eigen::VectorXd(), Eigen::VectorXd()).size(), 0);
}

NarxModel file_model() {
  NarxModel m = small_model(11);
  m.scaling.u_offset = 0.125;
  m.scaling.u_scale = 1.7;
  m.scaling.y_offset = -0.3;
  m.scaling.y_scale = 0.02;
  m.meta = {{"data", "sweep.csv"}, {"j_pct", 3.25}};
  return m;
}

TEST(NarxModel, SmallSignalResponseIsTheLinearisationAlongTheRestTrajectory) {
  const Scaling scaling{0.1, 0.5, -0.2, 2.0};
  const double a = 0.6, b = 1.3, c = 0.2, w = 0.9, d = 0.05;
  // one node, y(k) = w·tanh(a·y(k−1) + b·u(k) + c) + d, with offsets in the scaling, so the rest trajectory
  // is not zero and the linearisation's slope changes along it
  const NarxModel m = testing_support::one_node_narx(a, b, c, w, d, scaling, 1000.0);
  Eigen::VectorXd u(300);
  for (Eigen::Index k = 0; k < u.size(); ++k) u[k] = 0.4 * std::sin(0.07 * k) + 0.2 * std::sin(0.9 * k + 1.0);
  // closed form: rest r(k) = w·tanh(a·r(k−1) + b·u0 + c) + d from r(−1) = 0 with u0 the scaled zero input,
  // slope s(k) = w·(1 − tanh²(a·r(k−1) + b·u0 + c)), δy(k) = s(k)·(a·δy(k−1) + b·u(k)/u_scale), raw = y_scale·δy
  const double u0 = (0.0 - scaling.u_offset) / scaling.u_scale;
  double rest = 0.0, dy = 0.0, largest = 0.0;
  Eigen::VectorXd expected(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    const double t = std::tanh(a * rest + b * u0 + c);
    dy = w * (1.0 - t * t) * (a * dy + b * u[k] / scaling.u_scale);
    rest = w * t + d;
    expected[k] = scaling.y_scale * dy;
    largest = std::max(largest, std::abs(expected[k]));
  }
  const Eigen::VectorXd got = small_signal_response(m, u);
  ASSERT_EQ(got.size(), u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) ASSERT_NEAR(got[k], expected[k], 1e-7 * largest) << k;
  // linear in u, unlike the model itself: three times the input, three times the response
  EXPECT_LT((small_signal_response(m, 3.0 * u) - 3.0 * got).cwiseAbs().maxCoeff(), 1e-7 * largest);
  const auto swing = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
    return m.simulate(x) - m.simulate(Eigen::VectorXd::Zero(x.size()));
  };
  EXPECT_GT((swing(3.0 * u) - 3.0 * swing(u)).cwiseAbs().maxCoeff(), 0.05 * largest);
  // no input, no response; a non-finite input is named
  EXPECT_EQ(small_signal_response(m, Eigen::VectorXd::Zero(5)), Eigen::VectorXd::Zero(5));
  Eigen::VectorXd bad = u;
  bad[17] = std::nan("");
  expect_error<std::invalid_argument>([&] { small_signal_response(m, bad); }, "u");
}

TEST(NarxModelJson, RoundTripIsExact) {
  const NarxModel m = file_model();
  const nlohmann::json j = narx_model_to_json(m);
  EXPECT_EQ(j.at("format"), "panelbass.model/1");
  EXPECT_EQ(j.at("kind"), "narx");
  EXPECT_EQ(j.at("params").at("hidden"), nlohmann::json::array({3}));
  EXPECT_EQ(j.at("params").at("theta").size(), static_cast<std::size_t>(m.net.parameter_count()));
  // Through text, as a model file travels.
  const NarxModel back = narx_model_from_json(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(back.structure.na, 2);
  EXPECT_EQ(back.structure.nb, 1);
  EXPECT_EQ(back.structure.nk, 1);
  EXPECT_EQ(back.structure.hidden, std::vector<int>{3});
  EXPECT_EQ(back.net.parameters(), m.net.parameters());
  EXPECT_EQ(back.scaling.u_offset, m.scaling.u_offset);
  EXPECT_EQ(back.scaling.u_scale, m.scaling.u_scale);
  EXPECT_EQ(back.scaling.y_offset, m.scaling.y_offset);
  EXPECT_EQ(back.scaling.y_scale, m.scaling.y_scale);
  EXPECT_EQ(back.fs, m.fs);
  EXPECT_EQ(back.meta, m.meta);
  EXPECT_EQ(narx_model_to_json(back), j);
  const Eigen::VectorXd u = signal(50, 1.0, 0.3);
  EXPECT_EQ(back.simulate(u), m.simulate(u));
}

TEST(NarxModelJson, MetaIsOptional) {
  nlohmann::json j = narx_model_to_json(file_model());
  j.erase("meta");
  EXPECT_EQ(narx_model_from_json(j).meta, nlohmann::json::object());
}

// One valid file changed in one place must fail with a message naming the place.
TEST(NarxModelJson, EveryValidationFailureNamesTheKey) {
  const nlohmann::json valid = narx_model_to_json(file_model());
  ASSERT_NO_THROW(narx_model_from_json(valid));
  struct Case {
    const char* name;
    std::function<void(nlohmann::json&)> change;
    const char* message;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Case> cases = {
      {"not an object", [](nlohmann::json& j) { j = nlohmann::json::array(); }, "model: expected an object"},
      {"format missing", [](nlohmann::json& j) { j.erase("format"); }, "model.format: missing"},
      {"format wrong", [](nlohmann::json& j) { j["format"] = "panelbass.model/0"; }, "model.format: expected"},
      {"kind missing", [](nlohmann::json& j) { j.erase("kind"); }, "model.kind: missing"},
      {"kind linear", [](nlohmann::json& j) { j["kind"] = "linear"; }, "model.kind: expected \"narx\", got \"linear\""},
      {"fs missing", [](nlohmann::json& j) { j.erase("fs"); }, "model.fs: missing"},
      {"fs zero", [](nlohmann::json& j) { j["fs"] = 0.0; }, "model.fs: must be > 0"},
      {"fs text", [](nlohmann::json& j) { j["fs"] = "48k"; }, "model.fs: expected a number"},
      {"scaling missing", [](nlohmann::json& j) { j.erase("scaling"); }, "model.scaling: missing"},
      {"scaling negative", [](nlohmann::json& j) { j["scaling"]["u_scale"] = -1.0; }, "model.scaling.u_scale"},
      {"params missing", [](nlohmann::json& j) { j.erase("params"); }, "model.params: missing"},
      {"params not object", [](nlohmann::json& j) { j["params"] = 3; }, "model.params: expected an object"},
      {"na missing", [](nlohmann::json& j) { j["params"].erase("na"); }, "model.params.na: missing"},
      {"na negative", [](nlohmann::json& j) { j["params"]["na"] = -1; }, "model.params.na: must be within"},
      {"na fraction", [](nlohmann::json& j) { j["params"]["na"] = 1.5; }, "model.params.na: expected an integer"},
      {"nb missing", [](nlohmann::json& j) { j["params"].erase("nb"); }, "model.params.nb: missing"},
      {"nb text", [](nlohmann::json& j) { j["params"]["nb"] = "2"; }, "model.params.nb: expected an integer"},
      {"nk missing", [](nlohmann::json& j) { j["params"].erase("nk"); }, "model.params.nk: missing"},
      {"nk negative", [](nlohmann::json& j) { j["params"]["nk"] = -2; }, "model.params.nk: must be within"},
      {"too many inputs",
       [](nlohmann::json& j) {
         j["params"]["na"] = 600;
         j["params"]["nb"] = 400;
       },
       "model.params: na + nb + 1 = 1001"},
      {"hidden missing", [](nlohmann::json& j) { j["params"].erase("hidden"); }, "model.params.hidden: missing"},
      {"hidden empty", [](nlohmann::json& j) { j["params"]["hidden"] = nlohmann::json::array(); },
       "model.params.hidden: must name at least one"},
      {"hidden not array", [](nlohmann::json& j) { j["params"]["hidden"] = 3; }, "model.params.hidden: expected an array"},
      {"hidden zero width", [](nlohmann::json& j) { j["params"]["hidden"] = {3, 0}; }, "model.params.hidden[1]: must be within"},
      {"hidden fraction", [](nlohmann::json& j) { j["params"]["hidden"] = {2.5}; }, "model.params.hidden[0]: expected a positive integer"},
      {"theta missing", [](nlohmann::json& j) { j["params"].erase("theta"); }, "model.params.theta: missing"},
      {"theta not array", [](nlohmann::json& j) { j["params"]["theta"] = 1.0; }, "model.params.theta: expected an array"},
      {"theta short", [](nlohmann::json& j) { j["params"]["theta"].erase(0); }, "model.params.theta: expected 19 weights for this structure, got 18"},
      {"theta for another structure", [](nlohmann::json& j) { j["params"]["hidden"] = {4}; },
       "model.params.theta: expected 25 weights for this structure, got 19"},
      {"theta not finite", [nan](nlohmann::json& j) { j["params"]["theta"][3] = nan; }, "model.params.theta[3]: not finite"},
      {"theta text", [](nlohmann::json& j) { j["params"]["theta"][2] = "0.1"; }, "model.params.theta[2]: expected a number"},
      {"unknown top-level key", [](nlohmann::json& j) { j["extra"] = 1; }, "model.extra: unknown key"},
      {"unknown params key", [](nlohmann::json& j) { j["params"]["nc"] = 1; }, "model.params.nc: unknown key"},
      {"unknown scaling key", [](nlohmann::json& j) { j["scaling"]["gain"] = 1; }, "model.scaling.gain: unknown key"},
      {"meta not object", [](nlohmann::json& j) { j["meta"] = "x"; }, "model.meta: expected an object"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    nlohmann::json j = valid;
    c.change(j);
    expect_error<ConfigError>([&] { narx_model_from_json(j); }, c.message);
  }
}

// NN 2-1-1 with na = 1, nb = 0: ŷ(k) = v·tanh(w_y·ŷ(k−1) + w_u·u(k) + b) + c.
nlohmann::json one_node_file(double v) {
  NarxStructure s;
  s.na = 1;
  s.nb = 0;
  s.nk = 0;
  s.hidden = {1};
  NarxModel m = NarxModel::with_structure(s, Scaling{}, 1000.0);
  m.net.parameters() << 10.0, 0.0, 0.5, v, 0.0;
  return narx_model_to_json(m);
}

TEST(NarxModelJson, DivergingModelIsRejected) {
  // v = 150: ŷ(1) = 150·tanh(0.5) ≈ 69, ŷ(2) = 150·tanh(693.5) = 150 > 100.
  expect_error<ConfigError>([] { narx_model_from_json(one_node_file(150.0)); },
                            "model: the free run diverges (|y| > 100 after 2 samples)");
  // v = 90 stays within ±90 for any input: accepted.
  EXPECT_NO_THROW(narx_model_from_json(one_node_file(90.0)));
}

}  // namespace
}  // namespace panelbass::models

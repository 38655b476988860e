// The neural state-space model against independent computations: its window-loss gradient against central
// finite differences, its free run against a hand-written loop of the recursion, its start against the
// linear model it came from, the model file (round trip and failure modes), and training on a
// Wiener–Hammerstein system (Adam, then the L-BFGS polish) lowering the validation J below the linear model's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "models/io/config_error.h"
#include "models/kinds/model_file.h"
#include "models/linear/state_space.h"
#include "models/state_space_nn/ss_gradients.h"
#include "models/state_space_nn/ss_model.h"
#include "models/state_space_nn/ss_training.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

Eigen::VectorXd noise(Eigen::Index n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  Eigen::VectorXd x(n);
  for (auto& v : x) v = d(rng);
  return x;
}

// A small model with every part of θ non-zero (random, seeded), a stable A.
SsModel random_model(int encoder_hidden) {
  SsModel m;
  m.structure = {3, 5, 4, encoder_hidden};
  m.fs = 1000.0;
  m.theta = 0.3 * noise(m.structure.parameter_count(), 7);
  auto p = ss_parts(m.structure, m.theta.data());
  p.A = Eigen::MatrixXd::Identity(3, 3) * 0.8 + 0.1 * noise(9, 8).reshaped(3, 3);
  return m;
}

// Wiener–Hammerstein: a first-order low-pass, a saturation, another first-order filter.
Eigen::VectorXd wiener_hammerstein(const Eigen::VectorXd& u) {
  Eigen::VectorXd y(u.size());
  double a = 0.0, b = 0.0;
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    y(k) = b;
    a = 0.8 * a + 0.2 * u(k);
    b = 0.7 * b + 0.3 * std::tanh(2.0 * a);
  }
  return y;
}

TEST(SsGradients, EqualCentralFiniteDifferences) {
  for (const int encoder_hidden : {0, 4}) {
    const SsModel m = random_model(encoder_hidden);
    const Eigen::VectorXd u = noise(60, 1), y = 0.5 * noise(60, 2);
    const std::vector<Eigen::Index> starts{0, 5, 17, 40};
    const SsWindows windows{starts, 12};
    Eigen::VectorXd gradient;
    ss_window_loss(m, u, y, windows, &gradient);
    Eigen::VectorXd numeric(gradient.size());
    const double h = 1e-5;  // truncation ~h²·V''' ≈ 1e-10, rounding ~1e-16/h ≈ 1e-11
    for (Eigen::Index i = 0; i < gradient.size(); ++i) {
      SsModel plus = m, minus = m;
      plus.theta(i) += h;
      minus.theta(i) -= h;
      numeric(i) = (ss_window_loss(plus, u, y, windows, nullptr) - ss_window_loss(minus, u, y, windows, nullptr)) / (2 * h);
    }
    EXPECT_LT((gradient - numeric).norm(), 1e-6 * numeric.norm()) << "encoder_hidden " << encoder_hidden;
    EXPECT_GT(numeric.norm(), 1e-3);
  }
}

TEST(SsModel, FreeRunFollowsTheRecursionWrittenOut) {
  const SsModel m = random_model(2);
  const auto p = ss_parts(m.structure, m.theta.data());
  const Eigen::VectorXd u = noise(30, 3), y = noise(30, 4);
  const Eigen::Index init = 6;
  // x(init) = E·z + V2·tanh(V1·z + c1) + c2 with z = [y(5..2), u(5..2)]
  Eigen::VectorXd z(8);
  for (int i = 0; i < 4; ++i) {
    z(i) = y(init - 1 - i);
    z(4 + i) = u(init - 1 - i);
  }
  Eigen::VectorXd x = p.E * z + p.c2 + p.V2 * (p.V1 * z + p.c1).array().tanh().matrix();
  const Eigen::VectorXd sim = m.simulate_scaled(u, y, init);
  for (Eigen::Index k = 0; k < init; ++k) EXPECT_EQ(sim(k), y(k));
  for (Eigen::Index k = init; k < u.size(); ++k) {
    Eigen::VectorXd in(4);
    in << x, u(k);
    const Eigen::VectorXd out = p.W2 * (p.W1 * in + p.b1).array().tanh().matrix() + p.b2;
    const double yk = (p.C * x)(0) + p.D(0, 0) * u(k) + out(3);
    EXPECT_NEAR(sim(k), yk, 1e-12) << k;
    x = p.A * x + p.B * u(k) + out.head(3);
  }
}

TEST(SsModel, StartsExactlyAtTheLinearModel) {
  const Eigen::VectorXd u = noise(400, 5);
  LinearModel linear;
  linear.fs = 1000.0;
  linear.tf.a = Eigen::Vector2d(-1.2, 0.5);
  linear.tf.b = Eigen::Vector2d(0.3, 0.2);
  linear.tf.nk = 1;
  const Eigen::VectorXd y = linear.simulate(u);
  const SsModel m = ss_initial_model(linear, {6, 8, 10, 3}, u, y, 1);
  EXPECT_EQ(m.structure.states, realize(linear.tf).order());
  EXPECT_LT((m.simulate(u) - linear.simulate(u)).cwiseAbs().maxCoeff(), 1e-10);  // rounding of the balancing
  // The encoder's affine part recovers the state from 10 past samples of a noise-free second-order system.
  EXPECT_LT(j_percent(m.simulate(u, y, 50), y, 50), 1e-12);
}

TEST(SsModel, FileRoundTripsAndRefusesBadInput) {
  SsModel m = random_model(2);
  m.theta *= 0.3;
  const nlohmann::json j = ss_model_to_json(m);
  const AnyModel any = model_from_json(j);
  ASSERT_EQ(any.kind(), "ss");
  const Eigen::VectorXd u = noise(50, 6);
  EXPECT_EQ(any.simulate(u), m.simulate(u));
  nlohmann::json short_theta = j;
  short_theta["params"]["theta"].erase(0);
  EXPECT_THROW(ss_model_from_json(short_theta), ConfigError);
  nlohmann::json no_states = j;
  no_states["params"].erase("states");
  EXPECT_THROW(ss_model_from_json(no_states), ConfigError);
  nlohmann::json runaway = j;
  auto p = ss_parts(m.structure, m.theta.data());
  p.A = 1.5 * Eigen::MatrixXd::Identity(3, 3);
  runaway["params"]["theta"] = ss_model_to_json(m)["params"]["theta"];
  EXPECT_THROW(ss_model_from_json(runaway), ConfigError);
}

TEST(SsTraining, LowersTheValidationJBelowTheLinearStart) {
  const Eigen::VectorXd u = noise(6000, 9), y = wiener_hammerstein(u);
  const Eigen::VectorXd ue = u.head(4000), ye = y.head(4000), uv = u.tail(2000), yv = y.tail(2000);
  // The start: the small-signal linearisation, 0.2·2·0.3 q⁻¹ / ((1 − 0.8 q⁻¹)(1 − 0.7 q⁻¹)).
  LinearModel linear;
  linear.fs = 1000.0;
  linear.tf.a = Eigen::Vector2d(-1.5, 0.56);
  linear.tf.b = Eigen::VectorXd::Constant(1, 0.12);
  linear.tf.nk = 1;
  SsTrainingOptions options;
  options.window = 30;
  options.batch = 16;
  options.max_epochs = 15;
  options.adam.learning_rate = 3e-3;
  options.init = 20;
  const SsModel start = ss_initial_model(linear, {2, 10, 5, 0}, ue, ye, 1);
  const SsTraining trained = train_ss(start, ue, ye, uv, yv, options);
  const double j_start = trained.history.front().j_val_pct;
  // The J selected on is the J the model reports on the validation data from `init` on.
  EXPECT_NEAR(trained.j_val_pct, j_percent(trained.model.simulate(uv, yv, options.init), yv, options.init), 1e-9);
  EXPECT_LT(trained.j_val_pct, 0.2 * j_start) << "start " << j_start;
}

TEST(SsTraining, LbfgsPolishLowersTheSelectedJAndKeepsItsBest) {
  const Eigen::VectorXd u = noise(3000, 10), y = wiener_hammerstein(u);
  const Eigen::VectorXd ue = u.head(2000), ye = y.head(2000), uv = u.tail(1000), yv = y.tail(1000);
  LinearModel linear;
  linear.fs = 1000.0;
  linear.tf.a = Eigen::Vector2d(-1.5, 0.56);
  linear.tf.b = Eigen::VectorXd::Constant(1, 0.12);
  linear.tf.nk = 1;
  const SsModel start = ss_initial_model(linear, {2, 8, 5, 0}, ue, ye, 3);
  SsPolishOptions options;
  options.window = 50;
  options.iterations = 40;
  options.init = 20;
  const SsTraining polished = polish_ss(start, ue, ye, uv, yv, options);
  EXPECT_LT(polished.j_val_pct, 0.2 * polished.history.front().j_val_pct);
  double lowest = polished.history.front().j_val_pct;
  for (const auto& r : polished.history) lowest = std::min(lowest, r.j_val_pct);
  EXPECT_EQ(polished.j_val_pct, lowest);
  EXPECT_NEAR(polished.j_val_pct, j_percent(polished.model.simulate(uv, yv, 20), yv, 20), 1e-9);
}

}  // namespace
}  // namespace panelbass::models

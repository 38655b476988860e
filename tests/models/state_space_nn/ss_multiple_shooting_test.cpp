// Multiple shooting for the neural state-space model against independent computations: its gradient with
// respect to θ and to every window's free initial state against central finite differences; with the states
// chained (each window started where the one before ended) its error part against one long window's; its
// penalties written out; and the training lowering the validation J of a Wiener–Hammerstein system and
// keeping the iterate of the lowest one.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "models/state_space_nn/ss_gradients.h"
#include "models/state_space_nn/ss_multiple_shooting.h"
#include "models/state_space_nn/ss_training.h"
#include "models/validation/performance.h"
#include "tests/support/wiener_hammerstein_record.h"

namespace panelbass::models {
namespace {

using testing_support::mt_uniform_noise;

// nx = 3, 5 tanh nodes, 4 lags, an encoder with `encoder_hidden` nodes; every part of θ non-zero, A stable.
SsModel shooting_model(int encoder_hidden) {
  SsModel m;
  m.structure = {3, 5, 4, encoder_hidden};
  m.fs = 1000.0;
  m.theta = 0.3 * mt_uniform_noise(m.structure.parameter_count(), 17);
  ss_parts(m.structure, m.theta.data()).A = Eigen::MatrixXd::Identity(3, 3) * 0.8 + 0.1 * mt_uniform_noise(9, 18).reshaped(3, 3);
  return m;
}

TEST(SsMultipleShooting, GradientEqualsCentralFiniteDifferences) {
  const Eigen::VectorXd u = mt_uniform_noise(70, 1), y = 0.5 * mt_uniform_noise(70, 2);
  const std::vector<Eigen::Index> starts{6, 18, 30, 42};  // consecutive windows of 12 after 4 lags
  const SsWindows windows{starts, 12};
  for (const int encoder_hidden : {0, 2}) {
    const SsModel m = shooting_model(encoder_hidden);
    const Eigen::MatrixXd x0 = 0.4 * mt_uniform_noise(12, 3).reshaped(3, 4);
    const double rho = 0.7;
    Eigen::VectorXd gradient;
    Eigen::MatrixXd state_gradient;
    ss_shooting_loss(m, u, y, windows, x0, rho, &gradient, &state_gradient);
    const double h = 1e-5;
    Eigen::VectorXd numeric(m.theta.size());
    for (Eigen::Index i = 0; i < m.theta.size(); ++i) {
      SsModel plus = m, minus = m;
      plus.theta(i) += h;
      minus.theta(i) -= h;
      numeric(i) = (ss_shooting_loss(plus, u, y, windows, x0, rho, nullptr, nullptr) -
                    ss_shooting_loss(minus, u, y, windows, x0, rho, nullptr, nullptr)) / (2 * h);
    }
    EXPECT_LT((gradient - numeric).norm(), 1e-6 * numeric.norm()) << "θ, encoder_hidden " << encoder_hidden;
    Eigen::MatrixXd numeric_states(3, 4);
    for (Eigen::Index i = 0; i < x0.size(); ++i) {
      Eigen::MatrixXd plus = x0, minus = x0;
      plus(i) += h;
      minus(i) -= h;
      numeric_states(i) = (ss_shooting_loss(m, u, y, windows, plus, rho, nullptr, nullptr) -
                           ss_shooting_loss(m, u, y, windows, minus, rho, nullptr, nullptr)) / (2 * h);
    }
    EXPECT_LT((state_gradient - numeric_states).norm(), 1e-6 * numeric_states.norm())
        << "x0, encoder_hidden " << encoder_hidden;
    EXPECT_GT(numeric_states.norm(), 1e-3);
  }
}

TEST(SsMultipleShooting, ChainedStatesGiveTheLongWindowsErrorAndThePenaltiesWrittenOut) {
  const Eigen::VectorXd u = mt_uniform_noise(70, 4), y = 0.5 * mt_uniform_noise(70, 5);
  const SsModel m = shooting_model(2);
  const std::vector<Eigen::Index> starts{6, 21, 36};
  const SsWindows windows{starts, 15};
  // The chain: window 0 from the encoder, each next one from the state the one before ended in (each window's
  // end found by running it alone).
  Eigen::MatrixXd x0(3, 3);
  x0.col(0) = ss_encoded_states(m, u, y, {std::span(starts).first(1), 15});
  for (Eigen::Index w = 1; w < 3; ++w) {
    const std::vector<Eigen::Index> one{starts[static_cast<std::size_t>(w - 1)]};
    ss_window_loss_from_states(m, u, y, {one, 15}, x0.col(w - 1), [&](const Eigen::MatrixXd& end, Eigen::MatrixXd&) {
      x0.col(w) = end;
      return 0.0;
    }, nullptr, nullptr);
  }
  // ρ = 0: the error of one window of 45 samples from the encoder, the same mean over the same samples
  const std::vector<Eigen::Index> whole{6};
  EXPECT_NEAR(ss_shooting_loss(m, u, y, windows, x0, 0.0, nullptr, nullptr), ss_window_loss(m, u, y, {whole, 45}, nullptr),
              1e-14);
  // ρ > 0 with the chain: no continuity term, and the encoder's term its mismatch at the 2nd and 3rd starts
  const double rho = 2.0;
  const Eigen::MatrixXd encoded = ss_encoded_states(m, u, y, windows);
  const double expected = ss_window_loss(m, u, y, {whole, 45}, nullptr) + rho / 45.0 * (encoded - x0).squaredNorm();
  EXPECT_NEAR(ss_shooting_loss(m, u, y, windows, x0, rho, nullptr, nullptr), expected, 1e-13);
  // a gap of 0.1 in one entry of the last window's state (whose end no window continues from) adds ρ·0.01/(W·T)
  // for continuity, and changes the encoder's term
  Eigen::MatrixXd gapped = x0;
  gapped(1, 2) += 0.1;
  const double error_part = ss_shooting_loss(m, u, y, windows, gapped, 0.0, nullptr, nullptr);
  EXPECT_NEAR(ss_shooting_loss(m, u, y, windows, gapped, rho, nullptr, nullptr),
              error_part + rho / 45.0 * (0.01 + (encoded - gapped).squaredNorm()), 1e-13);
}

TEST(SsMultipleShooting, RefusesWindowsThatAreNotConsecutive) {
  const Eigen::VectorXd u = mt_uniform_noise(70, 6), y = mt_uniform_noise(70, 7);
  const std::vector<Eigen::Index> starts{6, 20};
  EXPECT_THROW(ss_shooting_loss(shooting_model(0), u, y, {starts, 12}, Eigen::MatrixXd::Zero(3, 2), 1.0, nullptr, nullptr),
               std::invalid_argument);
  const std::vector<Eigen::Index> consecutive{6, 18};
  EXPECT_THROW(ss_shooting_loss(shooting_model(0), u, y, {consecutive, 12}, Eigen::MatrixXd::Zero(3, 2), -1.0, nullptr, nullptr),
               std::invalid_argument);
}

TEST(SsMultipleShooting, TrainingLowersTheValidationJAndKeepsItsBest) {
  const Eigen::VectorXd u = mt_uniform_noise(3000, 10), y = testing_support::wiener_hammerstein(u);
  const Eigen::VectorXd ue = u.head(2000), ye = y.head(2000), uv = u.tail(1000), yv = y.tail(1000);
  const SsModel start = ss_initial_model(testing_support::wiener_hammerstein_linearisation(), {2, 8, 5, 0}, ue, ye, 3);
  SsShootingOptions options;
  options.window = 50;
  options.iterations = 40;
  options.init = 20;
  const SsTraining trained = train_ss_shooting(start, ue, ye, uv, yv, options);
  EXPECT_LT(trained.j_val_pct, 0.2 * trained.history.front().j_val_pct);
  double lowest = trained.history.front().j_val_pct;
  for (const auto& r : trained.history) lowest = std::min(lowest, r.j_val_pct);
  EXPECT_EQ(trained.j_val_pct, lowest);
  EXPECT_NEAR(trained.j_val_pct, j_percent(trained.model.simulate(uv, yv, 20), yv, 20), 1e-9);
}

}  // namespace
}  // namespace panelbass::models

// The initial state fitted per record: on a noise-free record that starts mid-stream the fitted x(0) is the
// record's own state (where the encoder's is not), the fit is a minimum of the MAP objective written out, the
// prior is the free run's sample statistics, and the file keeps the prior and refuses a bad one by name.
#include <gtest/gtest.h>

#include <string>

#include "models/io/config_error.h"
#include "models/state_space_nn/ss_initial_state.h"
#include "models/state_space_nn/ss_model.h"
#include "tests/support/expect_error.h"
#include "tests/support/noise.h"
#include "tests/support/ss_models.h"

namespace panelbass::models {
namespace {

using testing_support::gaussian;
using testing_support::message_of;
using testing_support::resonant_ss;
using testing_support::uniform_noise;

// The resonance with a cubic spring and a tanh layer; identity scaling, so scaled and raw units agree.
SsModel nonlinear_resonance() { return resonant_ss(40.0, 1000.0, 0.5, 0.1, 0.3, 0.2, 0.0, Scaling{}, 3); }

// The MAP objective of the fit, written out: Σ_{k<init} (y(k) − ŷ(k))²/σ² + (x − μ)ᵀ(Σ + floor·I)⁻¹(x − μ).
double map_objective(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init,
                     const Eigen::VectorXd& x) {
  const SsStatePrior& prior = *m.state_prior;
  const Eigen::Index n = x.size();
  const double floor = 1e-9 * prior.covariance.trace() / static_cast<double>(n);
  const Eigen::VectorXd e = y.head(init) - m.run_scaled(u, x, 0, init), d = x - prior.mean;
  const Eigen::MatrixXd covariance = prior.covariance + floor * Eigen::MatrixXd::Identity(n, n);
  return e.squaredNorm() / prior.noise_variance + d.dot(covariance.inverse() * d);
}

TEST(SsInitialState, AFittedStartIsTheRecordsOwnStateWhereTheEncodersIsNot) {
  SsModel m = nonlinear_resonance();
  // the prior from a record the model was "estimated" on: its own response plus a little noise
  const Eigen::VectorXd u_est = uniform_noise(4000, 1.0, 7);
  const Eigen::VectorXd y_est = m.simulate(u_est) + gaussian(u_est.size(), 1e-3, 8);
  m.state_prior = ss_state_prior(m, u_est, y_est, 20);
  // a noise-free record that starts mid-stream: the model's response from a state far from rest
  const Eigen::VectorXd u = uniform_noise(600, 1.0, 9), x_true = (Eigen::VectorXd(2) << 1.5, -1.2).finished();
  const Eigen::VectorXd y = m.run_scaled(u, x_true, 0, u.size());
  const Eigen::Index init = 20;

  const Eigen::VectorXd x_fit = ss_fit_initial_state(m, u, y, init);
  // within the prior's pull (σ² = 1e-6 against the states' spread) of the true state
  EXPECT_LT((x_fit - x_true).norm(), 1e-2 * x_true.norm()) << x_fit.transpose();
  const Eigen::VectorXd fitted_run = m.simulate(u, y, init);
  EXPECT_EQ(fitted_run.head(init), y.head(init));  // the measured samples stand as they are
  const double peak = y.cwiseAbs().maxCoeff();
  EXPECT_LT((fitted_run - y).cwiseAbs().maxCoeff(), 1e-4 * peak);
  // the same model with the encoder (lags 2, its rest state): a transient the fit does not have
  SsModel encoded = m;
  encoded.state_prior.reset();
  EXPECT_GT((encoded.simulate(u, y, init) - y).tail(u.size() - init).cwiseAbs().maxCoeff(), 1e-2 * peak);
  // a minimum of the objective written out: no step of 1e-3 along any axis lowers it
  const double at_fit = map_objective(m, u, y, init, x_fit);
  for (Eigen::Index i = 0; i < 2; ++i) {
    for (const double step : {-1e-3, 1e-3}) {
      Eigen::VectorXd moved = x_fit;
      moved(i) += step;
      EXPECT_GE(map_objective(m, u, y, init, moved), at_fit) << "state " << i << " step " << step;
    }
  }
}

TEST(SsInitialState, ThePriorIsTheFreeRunsSampleMeanCovarianceAndErrorPastTheTransient) {
  // linear and written out: x(k+1) = A·x + B·u, y = C·x + D·u from the encoder's rest state c2 = [0.3, −0.3]
  const SsModel m = resonant_ss(50.0, 1000.0, 0.4, 0.05, 0.0, 0.0, 0.3, Scaling{}, 1);
  const auto p = ss_parts(m.structure, m.theta.data());
  const Eigen::VectorXd u = uniform_noise(1500, 1.0, 4), y = gaussian(u.size(), 0.5, 5);
  const Eigen::Index init = 10, skip = init + 2 * m.structure.lags, count = u.size() - skip;
  // the encoder's state at init from the regressor [y(k−1), y(k−2), u(k−1), u(k−2)] (E·z + c2)
  Eigen::Vector4d z(y(init - 1), y(init - 2), u(init - 1), u(init - 2));
  Eigen::Vector2d x = p.E * z + p.c2;
  Eigen::MatrixXd states(2, count);
  double squared_error = 0.0;
  for (Eigen::Index k = init; k < u.size(); ++k) {
    if (k >= skip) {
      states.col(k - skip) = x;
      const double e = y(k) - (p.C * x)(0, 0) - p.D(0, 0) * u(k);
      squared_error += e * e;
    }
    x = p.A * x + p.B * u(k);
  }
  const Eigen::Vector2d mean = states.rowwise().mean();
  const Eigen::MatrixXd centred = states.colwise() - mean;
  const Eigen::Matrix2d covariance = centred * centred.transpose() / static_cast<double>(count - 1);

  const SsStatePrior prior = ss_state_prior(m, u, y, init);
  EXPECT_LT((prior.mean - mean).norm(), 1e-12);
  EXPECT_LT((prior.covariance - covariance).norm(), 1e-12 * covariance.norm());
  EXPECT_NEAR(prior.noise_variance, squared_error / static_cast<double>(count), 1e-12);
  EXPECT_THROW(ss_state_prior(m, u.head(init + 4), y.head(init + 4), init), std::invalid_argument);
}

TEST(SsInitialState, TheFileKeepsThePriorAndRefusesABadOneByName) {
  SsModel m = nonlinear_resonance();
  const Eigen::VectorXd u = uniform_noise(2000, 1.0, 11), y = m.simulate(u) + gaussian(u.size(), 1e-3, 12);
  m.state_prior = ss_state_prior(m, u, y, 20);
  const nlohmann::json j = ss_model_to_json(m);
  const SsModel read = ss_model_from_json(j);
  ASSERT_TRUE(read.state_prior.has_value());
  EXPECT_LT((read.state_prior->mean - m.state_prior->mean).norm(), 1e-15 + 1e-12 * m.state_prior->mean.norm());
  EXPECT_EQ(read.simulate(u, y, 20), m.simulate(u, y, 20));
  // without the member the encoder starts the run, as before the prior existed
  nlohmann::json encoder = j;
  encoder["params"].erase("initial_state");
  EXPECT_FALSE(ss_model_from_json(encoder).state_prior.has_value());

  nlohmann::json short_mean = j;
  short_mean["params"]["initial_state"]["state_mean"].erase(0);
  EXPECT_NE(message_of<ConfigError>([&] { ss_model_from_json(short_mean); }).find("model.params.initial_state.state_mean: expected 2"),
            std::string::npos);
  nlohmann::json asymmetric = j;
  asymmetric["params"]["initial_state"]["state_covariance"][0][1] = 5.0;
  EXPECT_NE(message_of<ConfigError>([&] { ss_model_from_json(asymmetric); }).find("state_covariance: not a covariance"), std::string::npos);
  nlohmann::json no_noise = j;
  no_noise["params"]["initial_state"]["noise_variance"] = 0.0;
  EXPECT_NE(message_of<ConfigError>([&] { ss_model_from_json(no_noise); }).find("initial_state.noise_variance"), std::string::npos);
  EXPECT_THROW(ss_fit_initial_state(SsModel{}, u, y, 20), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

// The MIMO output-error refinement: its steady-state error (computed on DFT lines) equals the error of the
// periodic steady state simulated by hand over one period; its exact Jacobian equals central finite
// differences; and the whole identification (FIR → Kung → Levenberg–Marquardt) of a lightly damped 3×3
// system from noisy periodic data reaches the J of the noise it was given.
#include "models/linear/mimo_oe_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "models/linear/mimo_identification.h"
#include "tests/support/mimo_systems.h"

namespace panelbass::models {
namespace {

using namespace testing_support;

TEST(MimoOeEstimatorTest, SteadyStateErrorEqualsTheSimulatedPeriodsError) {
  const MimoStateSpace truth = mimo_system({{0.8, 0.4}, {0.75, 1.9}}, 2, 3, 21);
  const MimoStateSpace model = mimo_system({{0.85, 0.45}, {0.7, 1.8}}, 2, 3, 22);
  std::vector<Eigen::MatrixXd> u, y;
  double by_hand = 0.0;
  for (std::uint64_t r = 0; r < 2; ++r) {
    u.push_back(gaussian_matrix(100, 2, 30 + r));
    y.push_back(steady_state_output(truth, u.back(), 20));
    by_hand += (steady_state_output(model, u.back(), 20) - y.back()).squaredNorm();
  }
  EXPECT_NEAR(steady_state_error(model, periodic_spectra(u, y)), by_hand, 1e-10 * by_hand);
}

TEST(MimoOeEstimatorTest, JacobianEqualsCentralFiniteDifferences) {
  MimoStateSpace start = mimo_system({{0.8, 0.4}, {0.6, 2.2}}, 2, 3, 41);
  // One real pole too: A grows by a 1×1 block.
  start.A.conservativeResize(5, 5);
  start.A.row(4).setZero();
  start.A.col(4).setZero();
  start.A(4, 4) = 0.5;
  start.B.conservativeResize(5, Eigen::NoChange);
  start.B.row(4) = gaussian_matrix(1, 2, 42);
  start.C.conservativeResize(Eigen::NoChange, 5);
  start.C.col(4) = gaussian_matrix(3, 1, 43);
  ModalStateSpace model = modal_form(start);
  ASSERT_EQ(model.sigma.size(), 2);
  ASSERT_EQ(model.real_poles.size(), 1);
  std::vector<Eigen::MatrixXd> u{gaussian_matrix(64, 2, 44), gaussian_matrix(64, 2, 45)};
  std::vector<Eigen::MatrixXd> y{gaussian_matrix(64, 3, 46), gaussian_matrix(64, 3, 47)};
  const PeriodicSpectra data = periodic_spectra(u, y);
  const Eigen::MatrixXd J = modal_jacobian(model, data);
  const Eigen::VectorXd theta = model.theta();
  Eigen::MatrixXd numeric(J.rows(), J.cols());
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    const double h = 1e-6 * std::max(1.0, std::abs(theta[i]));
    Eigen::VectorXd plus = theta, minus = theta;
    plus[i] += h;
    minus[i] -= h;
    ModalStateSpace a = model, b = model;
    a.set_theta(plus);
    b.set_theta(minus);
    numeric.col(i) = (modal_residuals(a, data) - modal_residuals(b, data)) / (2.0 * h);
  }
  EXPECT_LT((J - numeric).norm(), 1e-6 * J.norm());
  // The modal form is the same system: its residuals are those of the original state space.
  EXPECT_NEAR(modal_residuals(model, data).squaredNorm(), steady_state_error(start, data), 1e-9);
}

TEST(MimoOeEstimatorTest, LightlyDampedThreeByThreeSystemReachesTheNoiseFloor) {
  // Three lightly damped modes (pole radius 0.98 and 0.97: Q of about 25), 3 inputs, 3 outputs.
  const MimoStateSpace truth = mimo_system({{0.98, 0.3}, {0.97, 0.9}, {0.98, 2.0}}, 3, 3, 61);
  const Eigen::Index N = 512;
  const double sigma = 0.05;
  std::vector<Eigen::MatrixXd> u_est, y_est, u_val, y_val;
  double noise_energy = 0.0, output_energy = 0.0;
  for (std::uint64_t r = 0; r < 4; ++r) {
    const Eigen::MatrixXd u = gaussian_matrix(N, 3, 70 + r);
    const Eigen::MatrixXd y = steady_state_output(truth, u, 10);
    // Two periods, each with its own noise; the fit sees their mean.
    const Eigen::MatrixXd noise = 0.5 * sigma * (gaussian_matrix(N, 3, 80 + r) + gaussian_matrix(N, 3, 90 + r));
    (r < 3 ? u_est : u_val).push_back(u);
    (r < 3 ? y_est : y_val).push_back(y + noise);
    if (r == 3) {
      noise_energy = noise.squaredNorm();
      output_energy = (y + noise).squaredNorm();
    }
  }
  const double floor_pct = 100.0 * noise_energy / output_energy;
  MimoIdentificationSpec spec;
  spec.order = 6;
  spec.taps = 150;
  spec.max_iterations = 50;
  const MimoIdentification id = identify_mimo(u_est, y_est, u_val, y_val, spec);
  EXPECT_EQ(id.order, 6);
  EXPECT_LT(spectral_radius(id.model), 1.0);
  EXPECT_LT(id.refinement.j_val_pct, 1.15 * floor_pct) << "floor " << floor_pct << " %, Kung " << id.kung_j_val_pct << " %";
  EXPECT_GT(id.refinement.j_val_pct, 0.85 * floor_pct);
  EXPECT_LE(id.refinement.j_val_pct, id.kung_j_val_pct);
  // The reported J is the steady-state simulation's (raw units, computed again here by hand).
  const Eigen::MatrixXd y_model = steady_state_output(id.model, u_val[0], 60);
  EXPECT_NEAR(100.0 * (y_model - y_val[0]).squaredNorm() / output_energy, id.refinement.j_val_pct,
              1e-6 * id.refinement.j_val_pct);
}

}  // namespace
}  // namespace panelbass::models

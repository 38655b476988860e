// The gray-box model [M1]–[M3] fitted from the drive and the coil current alone (mirror_current_fit.h): it recovers
// a model from the current that model makes (up to the unobservable scale of x), a sensor joins with its scale,
// sign and delay found, the rescaling leaves the current unchanged, and bad input is named.
#include <gtest/gtest.h>

#include <cmath>

#include "dsp/excitation.h"
#include "models/control/mirror_current_fit.h"
#include "tests/support/expect_error.h"
#include "tests/support/mirror_models.h"

namespace panelbass::models {
namespace {

/// panel-exciter's model without its rest inductance and Le(i) (the fit leaves the coil's time constant to A(z)) but
/// with Le(x)'s slope, its drive through A(z) = 1 − 0.5·z⁻¹ + 0.1·z⁻²: a discrete model the current-only fit's
/// structure holds exactly.
MirrorModel current_fit_truth() {
  MirrorModel truth = testing_support::panel_exciter_mirror_model();
  for (std::size_t j : {0u, 2u, 3u}) truth.electrical[j] = 0.0;
  truth.drive_taps = {1.0, -0.5, 0.1, 0.0};
  return truth;
}

TEST(MirrorCurrentFit, RescalingTheDisplacementLeavesTheCurrentUnchanged) {
  const MirrorModel truth = current_fit_truth();
  const Eigen::VectorXd drive = testing_support::mirror_test_drive(3000, 5);
  const Eigen::VectorXd a = run_mirror_model(truth, drive, 0).i;
  const Eigen::VectorXd b = run_mirror_model(rescale_displacement(truth, 37.0), drive, 0).i;
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-9 * a.cwiseAbs().maxCoeff());
}

TEST(MirrorCurrentFit, AddingAnEddyBranchKeepsTheDrivesPathAndChangesTheBackEmfs) {
  // add_eddy_branch's A'(z) = A(z)·(1 + G_b(z)/e_R) over its first tap is exact but for the product's taps past z⁻³:
  // with A(z) = 1 only the branch's series past z⁻³ (g/e_R·(1 − p)·p³, p = e^{−ρ}: 1e-8 at ρ = 6) is dropped, so the
  // current of a model without back-EMF stays what it was; with the back-EMF the current moves (its path now has the
  // branch)
  MirrorModel truth = current_fit_truth();
  truth.drive_taps = {1.0, 0.0, 0.0, 0.0};
  const Eigen::VectorXd drive = testing_support::mirror_test_drive(3000, 5);
  MirrorModel still = truth;
  for (std::size_t j : {1u, 5u, 6u, 7u, 8u, 9u}) still.electrical[j] = 0.0;  // no back-EMF, no Le(x)
  const MirrorEddyBranch branch{0.6 * truth.electrical[4], 6.0};
  const Eigen::VectorXd before = run_mirror_model(still, drive, 0).i;
  const Eigen::VectorXd after = run_mirror_model(add_eddy_branch(still, branch), drive, 0).i;
  EXPECT_LT((after - before).cwiseAbs().maxCoeff(), 1e-6 * before.cwiseAbs().maxCoeff());
  EXPECT_EQ(add_eddy_branch(still, branch).drive_taps[0], 1.0);
  const Eigen::VectorXd moving = run_mirror_model(truth, drive, 0).i;
  const Eigen::VectorXd moving_after = run_mirror_model(add_eddy_branch(truth, branch), drive, 0).i;
  EXPECT_GT((moving_after - moving).cwiseAbs().maxCoeff(), 1e-3 * moving.cwiseAbs().maxCoeff());
}

TEST(MirrorCurrentFit, RecoversTheDiscreteModelFromItsCurrentAlone) {
  const MirrorModel truth = current_fit_truth();
  const Eigen::VectorXd drive = testing_support::mirror_test_drive(9000, 3);
  const MirrorRun rec = run_mirror_model(truth, drive, 2);
  const MirrorCurrentFit fit = fit_mirror_model_from_current(drive, rec.i, truth.fs);
  EXPECT_EQ(fit.current_lag, 2);
  EXPECT_LT(fit.current_j_val_pct, 1e-4);
  // the fitted model in the truth's units of x (its c0): each coefficient against the truth's, relative to the
  // linear coefficient it modifies
  const MirrorModel m = rescale_displacement(fit.model, truth.mechanical[0] / fit.model.mechanical[0]);
  const std::array<double, 11>& c = m.mechanical;
  const std::array<double, 11>& t = truth.mechanical;
  EXPECT_NEAR(c[0], t[0], 1e-9 * t[0]);
  const double c_tol = 2e-3;
  EXPECT_NEAR(c[2] / c[0], t[2] / t[0], c_tol * std::abs(t[2] / t[0])) << "Bl(x)'s b2";
  EXPECT_NEAR(c[5] / t[5], 1.0, 2e-2) << "damping";
  EXPECT_NEAR(c[6] / t[6], 1.0, 1e-4) << "K0/m";
  EXPECT_NEAR(c[7] / t[7], 1.0, c_tol) << "k1";
  EXPECT_NEAR(c[8] / t[8], 1.0, c_tol) << "k2";
  EXPECT_NEAR(c[9] / t[9], 1.0, 2e-2) << "friction";
  EXPECT_NEAR(c[3] / t[3], 1.0, 2e-2) << "reluctance";
  const std::array<double, 10>& e = m.electrical;
  const std::array<double, 10>& te = truth.electrical;
  EXPECT_NEAR(e[4] / te[4], 1.0, 1e-4) << "e_R";
  EXPECT_NEAR(e[5] / te[5], 1.0, 1e-4) << "Bl/gain";
  EXPECT_NEAR(e[8] / te[8], 1.0, 2e-2) << "i·dLe/dx";
  EXPECT_NEAR(e[1] / te[1], 1.0, 2e-2) << "Le(x)'s slope";
  for (std::size_t j = 1; j < 4; ++j) EXPECT_NEAR(m.drive_taps[j], truth.drive_taps[j], 1e-4) << "a" << j;
  EXPECT_NEAR(m.friction_velocity, truth.friction_velocity, 0.05 * truth.friction_velocity);
  EXPECT_FALSE(fit.damping_rise) << "no Rms(v) in the truth: c10 must not earn a place";
}

TEST(MirrorCurrentFit, RecoversTheMechanicalResistancesRiseWithVelocity) {
  // Rms(v) = Rms·(1 + r2·v²) with r2 set so that the resistance doubles at the record's peak velocity
  MirrorModel truth = current_fit_truth();
  const Eigen::VectorXd drive = testing_support::mirror_test_drive(9000, 3);
  const double v_peak = run_mirror_model(truth, drive, 0).v.cwiseAbs().maxCoeff();
  const double r2 = 1.0 / (v_peak * v_peak);
  truth.mechanical[10] = truth.mechanical[5] * r2;
  const MirrorRun rec = run_mirror_model(truth, drive, 1);
  const MirrorCurrentFit fit = fit_mirror_model_from_current(drive, rec.i, truth.fs);
  EXPECT_TRUE(fit.damping_rise);
  EXPECT_LT(fit.current_j_val_pct, 1e-3);
  const MirrorModel m = rescale_displacement(fit.model, truth.mechanical[0] / fit.model.mechanical[0]);
  EXPECT_NEAR(m.mechanical[10] / m.mechanical[5], r2, 0.03 * r2) << "r2 in the truth's (mm/s)⁻²";
  EXPECT_NEAR(m.mechanical[5] / truth.mechanical[5], 1.0, 2e-2) << "damping at rest";
}

TEST(MirrorCurrentFit, ASensorJoinsWithItsScaleSignAndDelayFound) {
  // an accelerometer of negative, unknown sensitivity three samples late: the fit finds the delay and the map
  const MirrorModel truth = current_fit_truth();
  const Eigen::VectorXd drive = testing_support::mirror_test_drive(9000, 4);
  const MirrorRun rec = run_mirror_model(truth, drive, 1);
  Eigen::VectorXd sensor = Eigen::VectorXd::Zero(drive.size());
  for (Eigen::Index k = 4; k < drive.size(); ++k) sensor[k] = -2e-4 * (rec.v[k - 2] - rec.v[k - 3]) * truth.fs;
  MirrorCurrentFitOptions options;
  options.sensor_kind = MirrorSensorKind::acceleration;
  const MirrorCurrentFit fit = fit_mirror_model_from_current(drive, rec.i, truth.fs, options, sensor);
  EXPECT_LT(fit.current_j_val_pct, 1e-3);
  EXPECT_LT(fit.sensor_j_val_pct, 1e-3);
  // acceleration a_k = (v_{k+1} − v_k)/h in the run: the sensor reads a_{k−3}
  EXPECT_EQ(fit.sensor_delay, 3);
  // the map's gain in the truth's units: s0 · (fit's x units per truth's mm)
  const double alpha = fit.model.mechanical[0] / truth.mechanical[0];
  EXPECT_NEAR(fit.sensor_taps[0] * alpha, -2e-4, 1e-6);
}

TEST(MirrorCurrentFit, NamesBadInput) {
  const Eigen::VectorXd drive = testing_support::mirror_test_drive(2000, 1);
  using testing_support::one_line_error;
  EXPECT_NE(one_line_error<std::invalid_argument>([&] { (void)fit_mirror_model_from_current(drive, Eigen::VectorXd::Zero(1999), 3000.0); })
                .find("same length"), std::string::npos);
  EXPECT_NE(one_line_error<std::invalid_argument>([&] { (void)fit_mirror_model_from_current(drive, Eigen::VectorXd::Zero(2000), 3000.0); })
                .find("current is zero"), std::string::npos);
  Eigen::VectorXd current = drive;
  current[17] = std::nan("");
  EXPECT_NE(one_line_error<std::invalid_argument>([&] { (void)fit_mirror_model_from_current(drive, current, 3000.0); })
                .find("sample 17"), std::string::npos);
  EXPECT_NE(one_line_error<std::invalid_argument>([&] { (void)fit_mirror_model_from_current(drive, drive, 3000.0, {}, drive); })
                .find("needs its kind"), std::string::npos);
  EXPECT_NE(one_line_error<std::invalid_argument>([&] { (void)mirror_sensor_kind("laser"); }).find("known: none"), std::string::npos);
}

}  // namespace
}  // namespace panelbass::models

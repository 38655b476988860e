// The mirror filter: exact where its model is (the compensated output of a plant that the model describes
// exactly equals the linear reference's to 1e-6), a gray-box fit that recovers a model from its own record,
// and the model file's round trip and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dsp/excitation.h"
#include "models/control/mirror_filter.h"
#include "models/io/config_error.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "tests/support/expect_error.h"
#include "tests/support/mirror_models.h"

namespace panelbass::models {
namespace {

MirrorModel exciter_model() { return testing_support::panel_exciter_mirror_model(); }

Eigen::VectorXd two_tone(Eigen::Index n, double fs) {
  Eigen::VectorXd p(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / fs;
    p[k] = 0.35 * std::sin(2.0 * std::numbers::pi * 40.0 * t) + 0.25 * std::sin(2.0 * std::numbers::pi * 130.0 * t);
  }
  return p;
}

TEST(MirrorFilter, CompensatedOutputEqualsTheLinearTargetOnAPlantItsModelDescribesExactly) {
  const MirrorModel model = exciter_model();
  const Eigen::VectorXd program = two_tone(6000, model.fs);
  // the target: the linear reference (every element at its rest value) driven by the program
  const Eigen::VectorXd target = simulate_mirror_model(model.linear(), program);
  const Eigen::VectorXd plain = simulate_mirror_model(model, program);
  const Eigen::VectorXd compensated = simulate_mirror_model(model, mirror_filter(model, program));
  const double scale = target.cwiseAbs().maxCoeff();
  // the nonlinearity is strong enough that the plant alone misses the target by far more than the tolerance
  EXPECT_GT((plain - target).cwiseAbs().maxCoeff() / scale, 0.05);
  EXPECT_LT((compensated - target).cwiseAbs().maxCoeff() / scale, 1e-6);
}

TEST(MirrorFilter, CompensatedOutputEqualsTheLinearTargetWithAnEddyCurrentBranch) {
  // the branch is linear: the reference keeps it, and the filter inverts it with the rest of [M1]
  MirrorModel model = exciter_model();
  model.eddy = {0.6 * model.electrical[4], 2.0};
  const Eigen::VectorXd program = two_tone(6000, model.fs);
  const Eigen::VectorXd target = simulate_mirror_model(model.linear(), program);
  const Eigen::VectorXd compensated = simulate_mirror_model(model, mirror_filter(model, program));
  const double scale = target.cwiseAbs().maxCoeff();
  EXPECT_LT((compensated - target).cwiseAbs().maxCoeff() / scale, 1e-6);
  // and the branch changes the model: without it the filter misses the target
  MirrorModel without = model;
  without.eddy = {};
  EXPECT_GT((simulate_mirror_model(model, mirror_filter(without, program)) - target).cwiseAbs().maxCoeff() / scale, 1e-3);
}

TEST(MirrorFilter, TheEddyCurrentBranchIsTheContinuousBranchWithTheCurrentHeld) {
  // no motion, no inductance, A(z) = 1: i_{k+1} = (w + g·j_k)/(e_R + g). With the current held at I over a sample,
  // L2·dj/dt = R2·(I − j) gives j(h) = I + (j_0 − I)·e^{−ρ} and the branch's voltage averaged over the sample
  // R2·(I − j_0)·(1 − e^{−ρ})/ρ: from rest, a held w makes I = w/(e_R + r_b·(1 − e^{−ρ})/ρ) in the first sample, and
  // w/e_R once L2 carries the current (at DC the branch is a short)
  MirrorModel m;
  m.electrical[4] = 0.2;
  m.mechanical[0] = 1.0;
  m.eddy = {0.125, 2.0};
  MirrorState s;
  const double w = 0.3, r2 = 0.125, rho = 2.0;
  step_mirror_model(m, s, w);
  const double first = w / (0.2 + r2 * (1.0 - std::exp(-rho)) / rho);
  EXPECT_NEAR(s.i, first, 1e-12);
  EXPECT_NEAR(s.eddy, first * (1.0 - std::exp(-rho)), 1e-12);
  for (int k = 0; k < 200; ++k) step_mirror_model(m, s, w);
  EXPECT_NEAR(s.i, w / 0.2, 1e-9);
}

TEST(MirrorFilter, AFreeRunHoldsEachSamplesStartAndStopsAtItsBound) {
  const MirrorModel model = exciter_model();
  const Eigen::VectorXd drive = two_tone(600, model.fs);
  const MirrorRun run = run_mirror_model(model, drive, 3);
  // the drive held three samples late: the run's first three samples at rest, then [M3] and the acceleration's
  // definition between consecutive states
  const double h = 1.0 / model.fs;
  for (Eigen::Index k = 0; k < 4; ++k) EXPECT_EQ(run.x[k], 0.0) << k;
  EXPECT_NE(run.i[5], 0.0);  // drive[0] is 0 (a sine from its zero), drive[1] acts over sample 4
  for (Eigen::Index k = 0; k + 1 < drive.size(); ++k) {
    ASSERT_NEAR(run.x[k + 1], run.x[k] + h * run.v[k + 1], 1e-12 * (1.0 + std::abs(run.x[k]))) << k;
    ASSERT_NEAR(run.a[k], (run.v[k + 1] - run.v[k]) / h, 1e-6 * (1.0 + std::abs(run.a[k]))) << k;
  }
  // the same drive on time gives the same run three samples earlier
  const MirrorRun early = run_mirror_model(model, drive, 0);
  EXPECT_EQ(early.i.head(500), run.i.segment(3, 500));
  // a bound under the current's peak stops the run, the rest NaN
  MirrorRun bounded;
  const double peak = run.i.cwiseAbs().maxCoeff();
  EXPECT_TRUE(run_mirror_model(model, drive, 3, bounded, 2.0 * peak));
  EXPECT_FALSE(run_mirror_model(model, drive, 3, bounded, 0.5 * peak));
  EXPECT_TRUE(std::isnan(bounded.i[drive.size() - 1]));
}

TEST(MirrorFilter, ExactThroughADrivePathFilter) {
  // the DA path as A(z) = 1 − 0.6·z⁻¹ + 0.2·z⁻² + 0.05·z⁻³ (minimum phase): the filter inverts it by 1/A(z)
  MirrorModel model = exciter_model();
  model.drive_taps = {1.0, -0.6, 0.2, 0.05};
  const Eigen::VectorXd program = two_tone(6000, model.fs);
  const Eigen::VectorXd target = simulate_mirror_model(model.linear(), program);
  const Eigen::VectorXd compensated = simulate_mirror_model(model, mirror_filter(model, program));
  EXPECT_LT((compensated - target).cwiseAbs().maxCoeff() / target.cwiseAbs().maxCoeff(), 1e-6);
}

TEST(MirrorFilter, FitRecoversTheDrivePathFilter) {
  // a model without inductance whose drive reaches the coil through A(z), two samples late: the fit finds
  // the delay, A(z) and the coefficients from the record the model makes
  MirrorModel truth = exciter_model();
  for (std::size_t j : {0u, 1u, 2u, 3u, 8u}) truth.electrical[j] = 0.0;  // no inductance, no i·dLe/dx back-EMF
  truth.drive_taps = {1.0, -1.1, 0.5, -0.1};
  const Eigen::VectorXd drive = 0.5 * dsp::gaussian_noise(12000, 0.4, 4).cwiseMax(-1.0).cwiseMin(1.0);
  const MirrorRun rec = run_mirror_model(truth, drive, 2);
  const MirrorFit fit = fit_mirror_model(drive, rec.i, rec.x / 1000.0, truth.fs, 4, MirrorRecordKind::discrete_model);
  EXPECT_EQ(fit.model.delay, 2);
  for (std::size_t j = 0; j < 4; ++j) EXPECT_NEAR(fit.model.drive_taps[j], truth.drive_taps[j], 1e-6) << "a" << j;
  EXPECT_NEAR(fit.model.electrical[4], truth.electrical[4], 1e-6 * truth.electrical[4]);
  EXPECT_NEAR(fit.model.electrical[5], truth.electrical[5], 1e-6 * truth.electrical[5]);
  EXPECT_LT(fit.electrical_fit_pct, 1e-8);
}

TEST(MirrorFilter, LinearModelPassesTheProgramUnchanged) {
  // on a linear model the mirror's current equation gives back the reference's current, so its drive is the
  // program itself: u = E_L·Δi/h + e_R·i + E_v·v is [M1] solved back for the drive
  const MirrorModel model = exciter_model().linear();
  const Eigen::VectorXd program = two_tone(3000, model.fs);
  EXPECT_LT((mirror_filter(model, program) - program).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(MirrorFilter, AForceFactorPastItsZeroIsHeldAtAQuarterOfItsRestValue) {
  // A model whose only nonlinearity is Bl(x)/m = c0·(1 − x²/X0²), with no inductance and A(z) = 1, driven so that
  // its linear reference swings to twice X0, where the fitted polynomial has changed sign (Le(i)'s card run: the
  // reference at 160 Hz left the record's displacements and the filter asked for ±150 at the drive). There the
  // filter's current is the reference's over β = max(Bl(x)/Bl(0), 1/4), so in closed form
  //   drive_k = program_k + e_R·i_ref,k+1·(1/β_k − 1)
  // (the reference's own [M1]: program_k = e_R·i_ref,k+1 + e5·v_ref,k+1; its [M2] shares c0, c5, c6 with the model).
  MirrorModel model;
  model.fs = 3000.0;
  model.electrical[4] = 0.25;                                   // e_R
  model.electrical[5] = 2e-4;                                   // Bl/gain
  model.mechanical = {5e5, 0.0, 0.0, 0.0, 0.0, -40.0, -8.9e5, 0.0, 0.0, 0.0};
  const double x0 = 2.0, quarter = 0.25;
  model.mechanical[2] = -model.mechanical[0] / (x0 * x0);
  const MirrorModel reference = model.linear();
  const auto sine = [&](double amplitude) {
    Eigen::VectorXd p(6000);
    for (Eigen::Index k = 0; k < p.size(); ++k) p[k] = amplitude * std::sin(2.0 * std::numbers::pi * 150.0 * k / model.fs);
    return p;
  };
  // the amplitude that takes the linear reference to 2·X0 (it is linear: its peak scales with the amplitude)
  double unit_peak = 0.0;
  {
    MirrorState s;
    const Eigen::VectorXd unit = sine(1.0);
    for (Eigen::Index k = 0; k < unit.size(); ++k) {
      step_mirror_model(reference, s, unit[k]);
      unit_peak = std::max(unit_peak, std::abs(s.x));
    }
  }
  const Eigen::VectorXd program = sine(2.0 * x0 / unit_peak);
  MirrorFilter filter(model);
  MirrorState ref;
  int held = 0, flagged = 0;
  double worst = 0.0, scale = 0.0;
  for (Eigen::Index k = 0; k < program.size(); ++k) {
    const double drive = filter.process(program[k]);
    step_mirror_model(reference, ref, program[k]);
    const double share = 1.0 - ref.x * ref.x / (x0 * x0);
    held += share < quarter;
    flagged += filter.saturated();
    const double expected = program[k] + model.electrical[4] * ref.i * (1.0 / std::max(share, quarter) - 1.0);
    worst = std::max(worst, std::abs(drive - expected));
    scale = std::max(scale, std::abs(expected));
  }
  EXPECT_GT(held, 100);  // the reference does pass the force factor's zero, often
  EXPECT_EQ(flagged, held);
  EXPECT_LT(worst, 1e-9 * scale);
}

TEST(MirrorFilter, FitRecoversTheModelFromItsOwnRecord) {
  // the fit leaves the inductance to A(z) (a time constant below a sample): a model without one is recovered
  MirrorModel truth = exciter_model();
  for (std::size_t j : {0u, 1u, 2u, 3u}) truth.electrical[j] = 0.0;
  // a record made by the model: drive in, current and displacement (m) out
  const Eigen::VectorXd drive = 0.8 * dsp::gaussian_noise(12000, 0.4, 3).cwiseMax(-1.0).cwiseMin(1.0);
  const MirrorRun rec = run_mirror_model(truth, drive, 0);
  const MirrorFit fit = fit_mirror_model(drive, rec.i, rec.x / 1000.0, truth.fs, 4, MirrorRecordKind::discrete_model);
  EXPECT_EQ(fit.model.delay, 0);  // record[k] is the state drive[k] starts from: no delay
  EXPECT_DOUBLE_EQ(fit.model.friction_velocity, 50.0);
  for (std::size_t j = 0; j < 10; ++j) {
    EXPECT_NEAR(fit.model.mechanical[j], truth.mechanical[j], 1e-6 * std::abs(truth.mechanical[0]) + 1e-6 * std::abs(truth.mechanical[6])) << "c" << j;
    EXPECT_NEAR(fit.model.electrical[j], truth.electrical[j], 1e-7 * std::abs(truth.electrical[4]) + 1e-9) << "e" << j;
  }
  EXPECT_LT(fit.electrical_fit_pct, 1e-8);
  EXPECT_LT(fit.mechanical_fit_pct, 1e-8);
}

TEST(MirrorFilter, FitOfASampledPlantFindsItsPhysics) {
  // panel-exciter without sensor noise, driven as bench/cancel.sh identifies it (a 10-300 Hz multisine at peak
  // 0.5): the fit finds the plant file's K0/m, Bl0/m and the shapes of K(x) and Bl(x), and its one-step
  // recursion resonates where the plant does, √(K0/m)/2π; the plain least-squares fit of the discrete equations
  // misses Bl0/m and b2 by 1-2 % (the sampled acceleration's sinc² shrinkage)
  PlantConfig plant = plant_preset("panel-exciter");
  plant.sensor.noise_rms_V = 0.0;
  dsp::MultisineSpec spec;
  spec.period = 30000;
  spec.f_min = 10.0;
  spec.f_max = 300.0;
  spec.amplitude = 0.5;
  const Eigen::VectorXd drive = dsp::multisine(spec).signal;
  const PlantRecord rec = simulate(plant, drive, 1);
  const MirrorFit fit = fit_mirror_model(drive, rec.i, rec.x, plant.fs);
  const std::array<double, 11>& c = fit.model.mechanical;
  const double h = 1.0 / plant.fs, k_over_m = plant.stiffness_N_per_m / plant.mass_kg;
  const double resonance = std::acos(1.0 + 0.5 * h * h * c[6]) / (2.0 * std::numbers::pi * h);
  EXPECT_NEAR(resonance, std::sqrt(k_over_m) / (2.0 * std::numbers::pi), 0.02);  // Hz, of 150
  EXPECT_NEAR(c[0] / c[6], -1000.0 * plant.Bl_Tm / plant.stiffness_N_per_m, 5e-4 * 1000.0 * plant.Bl_Tm / plant.stiffness_N_per_m);
  EXPECT_NEAR(c[7] / c[6], plant.nonlinear.stiffness.k1_per_mm, 0.005 * plant.nonlinear.stiffness.k1_per_mm);
  EXPECT_NEAR(c[8] / c[6], plant.nonlinear.stiffness.k2_per_mm2, 0.005 * plant.nonlinear.stiffness.k2_per_mm2);
  EXPECT_NEAR(c[2] / c[0], plant.nonlinear.force_factor.b2_per_mm2, 0.005 * std::abs(plant.nonlinear.force_factor.b2_per_mm2));
  const MirrorFit plain = fit_mirror_model(drive, rec.i, rec.x, plant.fs, 4, MirrorRecordKind::discrete_model);
  EXPECT_GT(std::abs(plain.model.mechanical[2] / plain.model.mechanical[0] / plant.nonlinear.force_factor.b2_per_mm2 - 1.0), 0.01);
}

TEST(MirrorFilter, ModelFileRoundTripsAndNamesBadInput) {
  const MirrorModel model = exciter_model();
  const MirrorModel back = mirror_model_from_json(mirror_model_to_json(model));
  EXPECT_EQ(back.electrical, model.electrical);
  EXPECT_EQ(back.mechanical, model.mechanical);
  EXPECT_EQ(back.friction_velocity, model.friction_velocity);
  nlohmann::json bad = mirror_model_to_json(model);
  bad["params"]["mechanical"].erase(3);
  bad["params"]["mechanical"].erase(3);
  EXPECT_NE(testing_support::one_line_error<ConfigError>([&] { (void)mirror_model_from_json(bad); }).find("model.params.mechanical: 11 coefficients expected (or 10), got 9"), std::string::npos);
  // a file written before Rms(v) joined [M2] stops at c9: c10 is 0
  nlohmann::json older = mirror_model_to_json(model);
  older["params"]["mechanical"].erase(10);
  MirrorModel expected = model;
  expected.mechanical[10] = 0.0;
  EXPECT_EQ(mirror_model_from_json(older).mechanical, expected.mechanical);
  // the eddy-current branch: written when there is one, read back; a file without it (before issue #56's fourth
  // session) has none; its values and its company named
  MirrorModel eddy = model;
  eddy.eddy = {0.07, 2.5};
  const nlohmann::json with_eddy = mirror_model_to_json(eddy);
  EXPECT_EQ(mirror_model_from_json(with_eddy).eddy.resistance, 0.07);
  EXPECT_EQ(mirror_model_from_json(with_eddy).eddy.rate, 2.5);
  EXPECT_FALSE(mirror_model_to_json(model)["params"].contains("eddy"));
  EXPECT_FALSE(mirror_model_from_json(mirror_model_to_json(model)).eddy.present());
  bad = with_eddy;
  bad["params"]["eddy"]["rate"] = 0.0;
  EXPECT_NE(testing_support::one_line_error<ConfigError>([&] { (void)mirror_model_from_json(bad); }).find("model.params.eddy.rate"), std::string::npos);
  bad = with_eddy;
  bad["params"]["eddy"].erase("resistance");
  EXPECT_NE(testing_support::one_line_error<ConfigError>([&] { (void)mirror_model_from_json(bad); }).find("model.params.eddy.resistance"), std::string::npos);
  bad = with_eddy;
  bad["params"]["observer"] = {{"sensor_taps", {1.0, 0.0, 0.0, 0.0}}, {"sensor_noise", 0.01}, {"process_noise_mm_per_s2", 1.0}};
  EXPECT_NE(testing_support::one_line_error<ConfigError>([&] { (void)mirror_model_from_json(bad); }).find("takes no eddy-current branch"), std::string::npos);
  bad = mirror_model_to_json(model);
  bad["params"].erase("electrical");
  EXPECT_NE(testing_support::one_line_error<ConfigError>([&] { (void)mirror_model_from_json(bad); }).find("model.params.electrical: missing"), std::string::npos);
  bad = mirror_model_to_json(model);
  bad["params"].erase("structure");  // a file of the model before the back-EMF moved to the sample's end
  EXPECT_NE(testing_support::one_line_error<ConfigError>([&] { (void)mirror_model_from_json(bad); }).find("model.params.structure: 2 expected"), std::string::npos);
  bad = mirror_model_to_json(model);
  bad["params"]["friction_velocity_mm_per_s"] = -1.0;
  EXPECT_NE(testing_support::one_line_error<ConfigError>([&] { (void)mirror_model_from_json(bad); }).find("friction_velocity_mm_per_s"), std::string::npos);
  EXPECT_NE(testing_support::one_line_error<std::invalid_argument>([&] { (void)fit_mirror_model(Eigen::VectorXd::Zero(2000), Eigen::VectorXd::Zero(1999),
                                         Eigen::VectorXd::Zero(2000), 3000.0); }).find("same length"), std::string::npos);
}

}  // namespace
}  // namespace panelbass::models

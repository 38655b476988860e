// The friction's velocity scale refitted on the current's harmonics of quiet sines (mirror_friction_refit.h): a
// model whose v0 is off by a known factor gets it back from the current the true model makes, a model without
// friction is left as it is, and bad input is named.
#include <gtest/gtest.h>

#include <cmath>

#include "dsp/excitation.h"
#include "models/control/mirror_current_fit.h"
#include "models/control/mirror_friction_refit.h"
#include "tests/support/expect_error.h"
#include "tests/support/mirror_models.h"

namespace panelbass::models {
namespace {

/// Stepped sines at `level` (37.5 and 75 Hz: a quarter and half panel-exciter's resonance), with the current
/// `truth` makes, its drive `lag` samples late.
CurrentSineRecord sines_through(const MirrorModel& truth, double level, int lag) {
  dsp::SteppedSineSpec spec;
  spec.fs = truth.fs;
  spec.amplitude = level;
  spec.frequencies = {37.5, 75.0};
  spec.settle = 1500;
  spec.measure = 4500;
  const dsp::SteppedSine sines = dsp::stepped_sine(spec);
  CurrentSineRecord r;
  r.drive = sines.signal;
  r.steps = sines.steps;
  r.current = run_mirror_model(truth, r.drive, lag).i;
  return r;
}

TEST(MirrorFrictionRefit, AVelocityScaleOffByAKnownFactorComesBack) {
  const MirrorModel truth = testing_support::panel_exciter_mirror_model();
  for (const double off : {0.6, 1.3, 2.5}) {
    MirrorModel guess = truth;
    guess.friction_velocity *= off;
    const FrictionScaleRefit r = refit_friction_scale(guess, 1, sines_through(truth, 0.1, 1), truth.fs);
    EXPECT_TRUE(r.used) << off;
    EXPECT_NEAR(r.scale * off, 1.0, 1e-3) << off;
    EXPECT_NEAR(r.model.friction_velocity, truth.friction_velocity, 1e-3 * truth.friction_velocity) << off;
    EXPECT_LT(r.error_after, 1e-6 * r.error_before) << off;
    // everything else is the model as given
    EXPECT_EQ(r.model.mechanical, guess.mechanical);
    EXPECT_EQ(r.model.electrical, guess.electrical);
    EXPECT_GT(r.harmonics_rms, 0.0);
  }
}

TEST(MirrorFrictionRefit, AModelThatAlreadyMatchesOrHasNoFrictionIsLeftAsItIs) {
  const MirrorModel truth = testing_support::panel_exciter_mirror_model();
  const FrictionScaleRefit same = refit_friction_scale(truth, 1, sines_through(truth, 0.1, 1), truth.fs);
  EXPECT_FALSE(same.used);
  EXPECT_EQ(same.scale, 1.0);
  EXPECT_EQ(same.model.friction_velocity, truth.friction_velocity);
  MirrorModel frictionless = truth;
  frictionless.mechanical[9] = 0.0;
  const FrictionScaleRefit none = refit_friction_scale(frictionless, 1, sines_through(frictionless, 0.1, 1), truth.fs);
  EXPECT_FALSE(none.used);  // v0 does nothing: no change lowers the error by 1 %
  EXPECT_EQ(none.model.friction_velocity, truth.friction_velocity);
}


TEST(MirrorFrictionRefit, AnEddyCurrentBranchIsFoundOnTheSinesWhereThereIsOneAndLeftOutWhereNot) {
  // panel-exciter's model without its rest inductance (the current fit's structure) with an eddy-current branch on the
  // search's grid (r_b = 0.6·e_R, ρ = 3): fitted from its multisine current without the branch, the search finds
  // that branch on its quiet sines; the same model without a branch gets none
  MirrorModel plain = testing_support::panel_exciter_mirror_model();
  for (std::size_t j : {0u, 3u}) plain.electrical[j] = 0.0;
  MirrorModel truth = plain;
  truth.eddy = {0.6 * truth.electrical[4], 3.0};
  const Eigen::VectorXd drive = testing_support::mirror_test_drive(9000, 3);
  for (const MirrorModel& m : {truth, plain}) {
    const Eigen::VectorXd current = run_mirror_model(m, drive, 1).i;
    const MirrorCurrentFit fit = fit_mirror_model_from_current(drive, current, m.fs);
    const EddyBranchSearch found = search_eddy_branch(fit.model, fit.current_lag, drive, current, sines_through(m, 0.1, 1), m.fs);
    ASSERT_FALSE(found.trials.empty());
    if (m.eddy.present()) {
      ASSERT_TRUE(found.used) << found.error_with << " vs " << found.error_without;
      // the refit moves e_R by a little beside the branch it holds
      EXPECT_NEAR(found.model.eddy.resistance / found.model.electrical[4], 0.6, 0.03);
      EXPECT_EQ(found.model.eddy.rate, 3.0);
      EXPECT_LT(found.error_with, 0.1 * found.error_without);
    } else {
      EXPECT_FALSE(found.used) << found.error_with << " vs " << found.error_without;
      EXPECT_FALSE(found.model.eddy.present());
      EXPECT_EQ(found.trials.size(), 3u);  // each rate's smallest branch made the harmonics worse: no larger one tried
    }
  }
}

TEST(MirrorFrictionRefit, NamesBadInput) {
  const MirrorModel truth = testing_support::panel_exciter_mirror_model();
  const CurrentSineRecord good = sines_through(truth, 0.1, 0);
  CurrentSineRecord r = good;
  r.steps.clear();
  testing_support::expect_invalid([&] { (void)refit_friction_scale(truth, 0, r, truth.fs); }, "no sine");
  r = good;
  r.current.conservativeResize(r.current.size() - 1);
  testing_support::expect_invalid([&] { (void)refit_friction_scale(truth, 0, r, truth.fs); }, "differ in length");
  r = good;
  r.current[10] = std::nan("");
  testing_support::expect_invalid([&] { (void)refit_friction_scale(truth, 0, r, truth.fs); }, "not finite");
  r = good;
  r.steps[1].measure_start = static_cast<std::size_t>(r.current.size());
  testing_support::expect_invalid([&] { (void)refit_friction_scale(truth, 0, r, truth.fs); }, "step 1");
  r = good;
  r.steps[0].frequency = 800.0;
  testing_support::expect_invalid([&] { (void)refit_friction_scale(truth, 0, r, truth.fs); }, "below fs/2");
  r = good;
  r.current.setZero();
  testing_support::expect_invalid([&] { (void)refit_friction_scale(truth, 0, r, truth.fs); }, "no fundamental");
}

}  // namespace
}  // namespace panelbass::models

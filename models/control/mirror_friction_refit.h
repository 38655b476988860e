#pragma once
// The friction's velocity scale v0 of a gray-box model [M1]–[M3] (mirror_filter.h) refitted where it shows: on the
// coil current's harmonics while the transducer plays quiet sines below its resonance (issue #56).
//
// The Coulomb friction c9·tanh(v/v0) is a force of constant size, so its distortion grows, relative to the rest,
// as the motion gets small, and its transition velocity v0 sets how: a mirror filter whose v0 is 10 % off cuts
// panel-exciter's THD at 40 and 80 Hz, program 0.1, by ~20 dB instead of 32. The multisine fit
// (mirror_current_fit.h) barely sees v0 — its current error changes by 0.1 % over ±20 % in v0, the motion being
// far above v0 most of the time, and the linear part's residual swamps it. The harmonics of a quiet sine's current,
// each relative to the fundamental (phase referred to it: dsp::HarmonicLevels::relative), are what the friction
// writes there, so v0 is fitted to them, every other coefficient held: the residual is the difference between the
// model's harmonics 2..5 and the record's, real and imaginary parts, over each sine's steady part. A coarse grid
// over ×/÷ 4.5 first (the current's harmonics are not convex in v0 far from the answer), then Levenberg–Marquardt
// (models/optimization) from the grid's best.

#include <Eigen/Core>
#include <vector>

#include "dsp/excitation.h"
#include "models/control/mirror_filter.h"

namespace panelbass::models {

/// Stepped sines the transducer was played (dsp::stepped_sine), with what its coil current did.
struct CurrentSineRecord {
  Eigen::VectorXd drive;              ///< as the converters delivered it (the loopback), or as sent
  Eigen::VectorXd current;            ///< the coil current, A
  std::vector<dsp::SineStep> steps;   ///< each sine's frequency and its steady, whole-period part
};

/// How the refit went.
struct FrictionScaleRefit {
  MirrorModel model;           ///< the model with v0 refitted (as given when the refit did not help)
  double scale = 1.0;          ///< v0 after over v0 before
  double error_before = 0.0;   ///< Σ |model's relative harmonic − record's|² over h = 2..5 and the steps, before
  double error_after = 0.0;    ///< the same after
  double harmonics_rms = 0.0;  ///< the record's relative harmonics 2..5, rms over the steps (what is matched)
  bool used = false;           ///< the refit lowered the error by 1 % and by more than rounding (else the model is as given)
};

/// Refits `model`'s friction velocity scale to the current's harmonics on `record`'s steps at `fs`, the model run from
/// rest over the whole record with its drive `current_lag` samples late (the current fit's lag L: negative when the
/// current leads the recorded drive). std::invalid_argument naming the problem for no step, drive and current of
/// unequal length, a non-finite sample, a step outside the record or under 4 periods, a frequency whose second
/// harmonic is not below fs/2, or a step whose current has no fundamental.
FrictionScaleRefit refit_friction_scale(const MirrorModel& model, int current_lag, const CurrentSineRecord& record, double fs);

/// One eddy-current branch tried.
struct EddyBranchTrial {
  MirrorEddyBranch branch;         ///< r_b (over the gain) and ρ
  double current_j_val_pct = 0.0;  ///< the current's J on validation of the multisine, refitted with it
  double harmonic_error = 0.0;     ///< the sines' harmonic error with it, v0 refitted (FrictionScaleRefit::error_after)
};

/// How the search for an eddy-current branch went.
struct EddyBranchSearch {
  MirrorModel model;                    ///< with the branch chosen, refitted, v0 refitted (as given when none earned it)
  bool used = false;                    ///< a branch earned its place
  double error_without = 0.0;           ///< the harmonic error of the model given, v0 refitted
  double error_with = 0.0;              ///< the chosen branch's (error_without when none)
  double current_j_val_pct = -1.0;      ///< the chosen model's current J on validation (−1: none chosen)
  std::vector<EddyBranchTrial> trials;  ///< every branch tried, in order
};

/// Searches [M1]'s eddy-current branch (mirror_filter.h) where it shows, in the current's harmonics on quiet sines
/// (issue #56): the multisine fit's current error barely tells the branch from A(z) and the other coefficients (on
/// panel-exciter-l2r2 the branch that makes the best filter raises J_val 0.004 → 0.011 %), the harmonics do. For each
/// rate ρ of a grid and r_b/e_R doubled from 0.3 while the harmonics improve, the multisine fit is continued with the
/// branch held (add_eddy_branch, then refit_mirror_model_from_current on `drive` and `current` from `model`, its current
/// `current_lag` samples behind), v0 refitted on `record`'s sines (refit_friction_scale), and the harmonic error
/// compared; the best branch is used when it cuts the error of `model` (v0 refitted the same way) by 20 %, makes no
/// sine's worse and leaves at most 2 % of the harmonics' own power (a model far off the sines has other mismatches a
/// branch would absorb). The sines must be quiet (kEddySearchLargestLevel): louder, the model's other mismatches write the
/// harmonics too, and at 0.2 a branch absorbed some of them on panel-exciter and panel-exciter-rms-v (the latter's 160 Hz
/// cut at 0.2 fell 14.5 → 7.1 dB with it). std::invalid_argument as refit_friction_scale's for a bad sine record.
EddyBranchSearch search_eddy_branch(const MirrorModel& model, int current_lag, const Eigen::VectorXd& drive,
                                    const Eigen::VectorXd& current, const CurrentSineRecord& record, double fs);

/// The loudest sines (drive peak) the eddy-current branch is searched on: on the plants of tests/support/plants at 0.1
/// no branch was chosen where the plant has none.
constexpr double kEddySearchLargestLevel = 0.1;

}  // namespace panelbass::models

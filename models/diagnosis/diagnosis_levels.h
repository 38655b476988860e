#pragma once
// Diagnosis, records at several levels (issue 58): what a finding removes from validation J at each drive level.
// A nonlinear effect's share of the output grows with the level (a cubic spring's by the level to the fourth
// power); a linear mismatch's does not (a missing mode or delay costs the same share of Σy² at any level). And
// where the main resonance moves with the level: in frequency for a spring, in decay rate for a damping.
// Folder-internal (namespace diagnosis_detail), used by the driver (diagnosis.cpp).

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/diagnosis_confidence.h"
#include "models/diagnosis/diagnosis_fit.h"
#include "models/diagnosis/diagnosis_terms.h"
#include "models/linear/linear_model.h"

namespace panelbass::models::diagnosis_detail {

/// The level exponent above which a gain grows with level: J's share ∝ level^slope, 0 for a linear mismatch,
/// 2 for a square law, 4 for a cube; 1 lies between.
inline constexpr double kGrowthSlope = 1.0;

/// The smallest ratio of drive levels over which growth is judged.
inline constexpr double kLevelSpan = 1.5;

/// Whether `effect` is a linear mismatch (a mode, a delay, creep): its share of J does not depend on the level.
bool is_linear_effect(Effect effect);

/// What a finding removed from validation J on one record.
struct LevelGain {
  std::string name;          ///< the record, as named by the caller
  double drive_rms = 0.0;    ///< the input's rms over the judged samples
  double j_before_pct = 0.0;
  double j_after_pct = 0.0;
};

/// How a finding's gain depends on the level, and whether that fits the effect named.
struct LevelVerdict {
  bool judged = false;       ///< two levels at least kLevelSpan apart, a gain at the highest
  double slope = 0.0;        ///< d ln(gain) / d ln(level) (least squares over the levels that gain; +inf when only the higher do)
  bool grows = false;        ///< slope > kGrowthSlope: nonlinear
  bool consistent = true;    ///< grows for a nonlinear effect, does not for a linear one (true when not judged)
  std::string sentence;      ///< the verdict in words ("" when not judged)
};

/// The verdict of `effect`'s gains over `levels` (a dc offset's share falls with level, as the output rises
/// around it: it is not judged).
LevelVerdict judge_levels(Effect effect, const std::vector<LevelGain>& levels);

/// The gains and the verdict as the report's JSON.
nlohmann::json levels_to_json(const std::vector<LevelGain>& levels, const LevelVerdict& verdict);

/// Judges finding `f` (its gain from `before` to `after`; its J on `diagnosed`, the validation record the diagnosis
/// ran on) on every record of `others` too, judged after `init` samples: sets `evidence.levels`, and when the growth
/// contradicts the effect calls it ambiguous, saying why; otherwise adds the verdict to its sentence.
void judge_at_levels(Finding& f, const AugmentedModel& before, const AugmentedModel& after, const LevelRecord& diagnosed,
                     const std::vector<LevelRecord>& others, Eigen::Index init);

/// The main resonance at one drive level: the pole s = −σ ± jω_d of the linear model identified on each of
/// kLevelParts parts of the record, as its undamped frequency ω = |s| (rad/s) and decay rate σ (1/s), the parts' mean.
struct LevelResonance {
  std::string name;
  double drive_rms = 0.0;
  bool found = false;            ///< every part has a pole near the baseline's main resonance
  double omega = 0.0, sigma = 0.0;
  double omega_sd = 0.0, sigma_sd = 0.0;  ///< the parts' standard deviation
};

/// Where the main resonance moves between the quietest and the loudest record. A spring that stiffens with the
/// level moves it along ω and leaves σ = c/2m; a damping that grows with the velocity moves it along σ and leaves
/// ω = √(k/m): the fundamental's describing function in phase with the displacement or with the velocity (what the
/// phase of a sine's third harmonic shows, on a noise drive).
struct ResonanceShift {
  bool judged = false;           ///< a main resonance at both ends, levels at least kLevelSpan apart
  double d_omega = 0.0, d_sigma = 0.0;    ///< loudest − quietest, rad/s and 1/s
  double sd_omega = 0.0, sd_sigma = 0.0;  ///< their standard uncertainty, from the parts' spread
  std::string moves;             ///< "frequency" (a spring), "decay" (a damping that rises with the speed: Rms(v)),
                                 ///< "decay_falls" (one that falls: friction), or "neither" (not told)
  std::string sentence;
  std::vector<LevelResonance> levels;
};

/// The parts each level's record is cut into, each identified on its own.
inline constexpr int kLevelParts = 4;

/// How many standard uncertainties the moving coordinate must shift, and how many times the other's shift it must
/// be (both in rad/s: the pole's path in the s-plane along one axis).
inline constexpr double kShiftZ = 4.0;
inline constexpr double kShiftDirection = 2.0;

/// The main resonance of `baseline` (the complex pole pair of the highest response peak, damping ratio 0.01–0.3,
/// below fs/4) at the level of each of `levels` (after `init` samples), and where it moves from the quietest to
/// the loudest.
ResonanceShift resonance_shift(const LinearModel& baseline, const std::vector<LevelRecord>& levels, Eigen::Index init);

/// The same over the diagnosed validation record `diagnosed` and the records at `others` levels.
ResonanceShift resonance_shift(const LinearModel& baseline, const LevelRecord& diagnosed, const std::vector<LevelRecord>& others,
                               Eigen::Index init);

/// Whether `a` and `b` are a cubic spring and a nonlinear damping (either way round): what the shift tells apart.
bool spring_or_damping(Effect a, Effect b);

/// Between a cubic spring and a nonlinear damping that look alike from the drive (`chosen` and `rival`, BIC margin
/// `drive_margin` on the effective samples; `confidence` their "ambiguous" verdict): when `shift` moves along ω, or
/// along σ with the damping rising, the effect it names becomes `chosen`, the other `rival`, and the word "likely";
/// otherwise the sentence says what the levels showed.
void name_by_resonance_shift(const ResonanceShift& shift, const Candidate*& chosen, const Candidate*& rival, double drive_margin,
                             FindingConfidence& confidence);

/// The shift as the report's JSON.
nlohmann::json resonance_shift_to_json(const ResonanceShift& shift);

}  // namespace panelbass::models::diagnosis_detail

#pragma once
// Diagnosis, records at several levels (issue 58): what a finding removes from validation J at each drive level.
// A nonlinear effect's share of the output grows with the level (a cubic spring's by the level to the fourth
// power); a linear mismatch's does not (a missing mode or delay costs the same share of Σy² at any level).
// Folder-internal (namespace diagnosis_detail), used by the driver (diagnosis.cpp).

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/diagnosis_terms.h"

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

}  // namespace panelbass::models::diagnosis_detail

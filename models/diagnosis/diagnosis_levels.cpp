#include "models/diagnosis/diagnosis_levels.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "models/diagnosis/diagnosis_fit.h"
#include "models/validation/performance.h"

namespace panelbass::models::diagnosis_detail {
namespace {

// The rms of `u` after its first `init` samples.
double rms_after(const Eigen::VectorXd& u, Eigen::Index init) {
  const Eigen::Index n = u.size() - init;
  return n > 0 ? std::sqrt(u.tail(n).squaredNorm() / static_cast<double>(n)) : 0.0;
}

}  // namespace

bool is_linear_effect(Effect effect) {
  return effect == Effect::resonance || effect == Effect::antiresonance || effect == Effect::delay || effect == Effect::creep;
}

LevelVerdict judge_levels(Effect effect, const std::vector<LevelGain>& levels) {
  LevelVerdict v;
  if (effect == Effect::dc_offset || levels.size() < 2) return v;
  std::vector<LevelGain> sorted = levels;
  std::sort(sorted.begin(), sorted.end(), [](const LevelGain& a, const LevelGain& b) { return a.drive_rms < b.drive_rms; });
  const LevelGain &low = sorted.front(), &high = sorted.back();
  if (!(low.drive_rms > 0.0) || high.drive_rms < kLevelSpan * low.drive_rms) return v;
  const auto gain = [](const LevelGain& g) { return g.j_before_pct - g.j_after_pct; };
  if (!(gain(high) > 0.0)) return v;
  // ln(gain) = a + slope·ln(level), least squares over the levels where the finding gains.
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
  int n = 0;
  for (const LevelGain& g : sorted)
    if (gain(g) > 0.0) {
      const double x = std::log(g.drive_rms), y = std::log(gain(g));
      sx += x, sy += y, sxx += x * x, sxy += x * y, ++n;
    }
  const double spread = n * sxx - sx * sx;
  // Only the higher levels gain: it grows, at a rate the data do not give.
  v.slope = n >= 2 && spread > 0.0 ? (n * sxy - sx * sy) / spread : std::numeric_limits<double>::infinity();
  v.judged = true;
  v.grows = v.slope > kGrowthSlope;
  v.consistent = is_linear_effect(effect) ? !v.grows : v.grows;
  const std::string span = std::to_string(sorted.size()) + " levels (drive rms " + fixed(low.drive_rms, 3) + "–" +
                           fixed(high.drive_rms, 3) + ")";
  const std::string rate = std::isfinite(v.slope) ? "as the level to the power " + fixed(v.slope, 1) : "only at the higher levels";
  const std::string name = to_string(effect);
  if (v.grows)
    v.sentence = "its gain in J grows with the drive over " + span + ", " + rate + ": nonlinear" +
                 (v.consistent ? ", as " + name + " is" : ", which " + name + " (a linear mismatch) is not");
  else
    v.sentence = "its gain in J does not grow with the drive over " + span + " (" + rate + "): a linear mismatch" +
                 (v.consistent ? ", as " + name + " is" : ", not the nonlinear " + name);
  return v;
}

nlohmann::json levels_to_json(const std::vector<LevelGain>& levels, const LevelVerdict& verdict) {
  nlohmann::json records = nlohmann::json::array();
  for (const LevelGain& g : levels)
    records.push_back({{"record", g.name}, {"drive_rms", g.drive_rms}, {"J_val_before_pct", g.j_before_pct},
                       {"J_val_after_pct", g.j_after_pct}});
  return {{"records", records},
          {"judged", verdict.judged},
          {"slope", verdict.judged && std::isfinite(verdict.slope) ? nlohmann::json(verdict.slope) : nlohmann::json(nullptr)},
          {"grows_with_level", verdict.grows},
          {"consistent", verdict.consistent},
          {"sentence", verdict.sentence}};
}

void judge_at_levels(Finding& f, const AugmentedModel& before, const AugmentedModel& after, const LevelRecord& diagnosed,
                     const std::vector<LevelRecord>& others, Eigen::Index init) {
  if (others.empty()) return;
  std::vector<LevelGain> gains{{diagnosed.name, rms_after(diagnosed.u, init), f.j_val_before_pct, f.j_val_after_pct}};
  for (const LevelRecord& level : others)
    gains.push_back({level.name, rms_after(level.u, init), j_percent(simulate_augmented(before, level.u, level.y, init), level.y, init),
                     j_percent(simulate_augmented(after, level.u, level.y, init), level.y, init)});
  const LevelVerdict verdict = judge_levels(f.effect, gains);
  f.evidence["levels"] = levels_to_json(gains, verdict);
  if (!verdict.judged) return;
  const std::string sentence = f.confidence.value("sentence", "");
  if (!verdict.consistent) {
    f.confidence["word"] = "ambiguous";
    f.confidence["sentence"] = "ambiguous: " + verdict.sentence + ". " + sentence;
  } else {
    f.confidence["sentence"] = sentence + " Levels: " + verdict.sentence + ".";
  }
}

}  // namespace panelbass::models::diagnosis_detail

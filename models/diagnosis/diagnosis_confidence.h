#pragma once
// Diagnosis, how sure: each kept augmentation against the best candidate of another effect in the same round
// (the runner-up), by the BIC on the validation residual's effective samples, in one plain word; and what a
// diagnosis leaves unexplained above the noise floor, with where it lies. Folder-internal
// (namespace diagnosis_detail), used by the driver (diagnosis.cpp).

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis_candidates.h"

namespace panelbass::models::diagnosis_detail {

/// Margins of the BIC (Kass and Raftery's scale of 2·ln B): from 10 "very strong", from 2 "positive".
inline constexpr double kClearMargin = 10.0;
inline constexpr double kLikelyMargin = 2.0;

/// How sure a finding is: its runner-up, the margin between them, and the plain word.
struct FindingConfidence {
  std::string word;                 ///< "clear", "likely" or "ambiguous"
  std::string runner_up;            ///< the best candidate of another effect ("" when none earned its parameters)
  std::string runner_up_variant;
  double margin_bic = 0.0;          ///< BIC of the finding minus the runner-up's, on the effective samples
  double explained_share = 0.0;     ///< the finding's drop in J over the excess of J above the noise floor, ≤ 1
  std::string sentence;             ///< the word in a sentence: "clear: …", "ambiguous between X and Y: …"
};

/// The confidence of `chosen` (one of `scored`) in a round that started at validation J `j_before` %, with
/// `effective_samples` of a coloured validation residual and a noise floor of `noise_floor_pct` %.
FindingConfidence judge_finding(const Candidate& chosen, const std::vector<Candidate>& scored, double j_before,
                                double effective_samples, double noise_floor_pct);

/// The confidence as the report's JSON.
nlohmann::json confidence_to_json(const FindingConfidence& c);

/// An effect that earned its parameters alone in the round of a finding (BIC `score_alone` on the validation samples).
struct EarnedAlone {
  Effect effect;
  double score_alone = 0.0;
};

/// After finding `f` (its round's earners `earned`, the effects kept since in `kept`): each earner that no longer earns
/// beside it in the next round (`scored`, BIC `score`) is one its term took in — a cubic spring's x³ inside Bl(x²)'s
/// x²·u — so the drive does not exclude it beside the finding: listed in `confidence.not_excluded` and
/// `evidence.not_excluded` (with both scores), and said in the sentence.
void note_not_excluded(Finding& f, const std::vector<EarnedAlone>& earned, const std::vector<Candidate>& scored,
                       const std::function<double(const Candidate&)>& score, const std::vector<Effect>& kept);

/// What is left above the noise floor after the findings (null when J is at the floor): its share of J, and
/// where the residual `after` lies — the frequency, the input level, the state, the time — in a sentence.
nlohmann::json unexplained_residual(double j_val_pct, double noise_floor_pct, const ResidualLocation& after);

}  // namespace panelbass::models::diagnosis_detail

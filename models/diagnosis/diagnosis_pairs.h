#pragma once
// Diagnosis, two effects at once (issue 58): when the round's best leaves structured residual, the leading
// gray-box candidates are fitted in pairs, jointly; a pair is kept when it scores better than the best single
// (BIC) and each of its two terms, added to the other, removes more of the validation residual than noise lets
// one of the pairs tried remove. Look-alikes (a coil offset and an asymmetric spring, Rms(v) and friction, a
// cubic spring and Bl(x²)) are what a single round cannot see together. Folder-internal (diagnosis_detail).

#include <functional>
#include <optional>
#include <vector>

#include "models/diagnosis/diagnosis_candidates.h"
#include "models/diagnosis/diagnosis_stopping.h"

namespace panelbass::models::diagnosis_detail {

/// The candidates a round pairs: the best-scoring gray-box terms of this many effects.
inline constexpr int kPairedEffects = 4;

/// A pair kept: its two candidates (the better alone first) and their joint fit.
struct JointPair {
  const Candidate* first = nullptr;   ///< the member that scores better alone
  const Candidate* second = nullptr;
  Fit fit;                             ///< both terms (and every earlier one) fitted at once
  int parameters = 0;
  ValidationGain second_given_first;   ///< what the second adds to the first alone
  ValidationGain first_given_second;   ///< what the first adds to the second alone
  int tried = 0;                       ///< pairs fitted
};

/// The best pair of the leading candidates of `scored` (gray-box terms added to `current`'s own linear part), when
/// it beats `best_single_score` (BIC on `n_val` validation samples) and both its members pass; `residual` gives a
/// model's validation residual.
std::optional<JointPair> best_joint_pair(const Records& r, const Fit& current, const std::vector<Candidate>& scored,
                                         double best_single_score, double n_val,
                                         const std::function<Eigen::VectorXd(const AugmentedModel&)>& residual);

/// The pair's two findings: the first from `current` to it alone, the second from there to the pair, each judged by
/// what it adds beside the other (BIC margin on `effective_samples` of the validation residual, the t of its gain);
/// `where` is the estimation residual's location (for the explanations).
/// Without the coil current (`with_current` false), a member with no drive signature of its own (Rms(v), a coil
/// offset) comes second and is called ambiguous with its partner, as a single finding of it is.
std::vector<Finding> pair_findings(const Records& r, const JointPair& pair, const Fit& current, double effective_samples,
                                   const ResidualLocation& where, bool with_current);

}  // namespace panelbass::models::diagnosis_detail

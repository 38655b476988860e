#pragma once
// Diagnosis, effects that look alike from the drive (issue 58): which of a round's candidates are look-alikes of
// the one it keeps, how the coil current's force channel decides between them, and — two effects at once — the
// second force the force channel shows beside the one kept, which the drive's rounds cannot see (its term
// collinear with the first's through the drive's dynamics, or too small there to earn). Folder-internal
// (namespace diagnosis_detail), used by the driver (diagnosis.cpp).

#include <functional>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "models/diagnosis/diagnosis_candidates.h"
#include "models/diagnosis/diagnosis_confidence.h"
#include "models/diagnosis/diagnosis_current.h"

namespace panelbass::models::diagnosis_detail {

/// The look-alikes of `chosen` among `scored` that earned their parameters (`score` > 0); with `closed`, their
/// look-alikes too, and so on (a force factor's look-alike Rms(v) brings in Rms(v)'s look-alike, a cubic spring).
std::vector<const Candidate*> look_alikes_of(const Candidate& chosen, const std::vector<Candidate>& scored,
                                             const std::function<double(const Candidate&)>& score, bool closed = false);

/// Between `chosen` and its look-alikes `alikes` the force channel decides: the best force score of the effects
/// that act as a force of the motion, if it earns kLikelyMargin; otherwise an effect of the look-alikes that is no
/// such force (the channel shows none missing: inductance); otherwise `chosen`. The verdict as JSON in `verdict`,
/// the confidence in `confidence`.
const Candidate* decided_by_current(const Candidate* chosen, const std::vector<const Candidate*>& alikes,
                                    const ForceChannel& channel, const Records& r, const Fit& current,
                                    const std::vector<Effect>& kept, nlohmann::json& verdict, FindingConfidence& confidence);

/// The force channel's BIC a second force must earn beside the first to be found with it (on the channel's
/// validation samples; a spurious partner after one concealed force scored ≤ 0 in the probes, a concealed
/// partner 265–540: docs/diagnosis.md).
inline constexpr double kPartnerMargin = 20.0;

/// How many times a look-alike partner's force score alone the finding's own must be for the two to count as two
/// effects rather than one force in two shapes (set on the probes' seeds 1–2 of the second family: docs/diagnosis.md).
inline constexpr double kLookAlikeDominance = 2.0;

/// A second force found beside a round's finding by the force channel.
struct ForcePartner {
  const Candidate* candidate = nullptr;  ///< the round's candidate of that effect (its drive-side term)
  ForceScore beside;                     ///< its force score with the round's finding (and the earlier ones) kept
  ForceScore chosen_beside;              ///< the finding's own force score with the partner kept
  double chosen_alone = 0.0;             ///< a look-alike pair's force scores alone (with the earlier findings only)
  double partner_alone = 0.0;
  std::string runner_up;                 ///< the next-best force beside the finding ("" when none)
  double runner_up_score = 0.0;
  nlohmann::json scores;                 ///< every force's score beside the finding
};

/// The best force of the motion (not `chosen`'s effect, none of `kept`) whose features, beside `chosen`'s and the
/// earlier findings', earn kPartnerMargin on the force channel, while `chosen`'s own force still earns
/// kLikelyMargin beside it (else the partner explains the same force, and is no second effect); it needs a
/// candidate of its own among `scored` that adds one term to `current`; a look-alike of `chosen` must also have
/// scored alone less than 1/kLookAlikeDominance of `chosen`'s own score; a coil offset is no partner of an asymmetric
/// spring (it earns beside a spring alone). Only when `chosen` acts as a force.
std::optional<ForcePartner> force_partner(const ForceChannel& channel, const Records& r, const Fit& current,
                                          const Candidate& chosen, const std::vector<Candidate>& scored,
                                          const std::vector<Effect>& kept);

/// With the current, in the first round when no candidate earns its parameters on the drive: the force whose
/// features earn most on the force channel, when that is kPartnerMargin or more (on the effect-free records of
/// both families every force scored −51 to −37: docs/diagnosis.md); its runner-up the next force.
std::optional<ForcePartner> force_lead(const ForceChannel& channel, const Records& r, const Fit& current,
                                       const std::vector<Candidate>& scored, const std::vector<Effect>& kept);

/// Two forces found together on the force channel.
struct ForcePair {
  ForcePartner lead;     ///< the first: its score beside the second, its runner-up the next force beside the second
  ForcePartner partner;  ///< the second: its score beside the first (chosen_beside: the first's beside it)
  double joint_score = 0.0;  ///< the two features' BIC together against neither
  int pairs_tried = 0;
};

/// With the current, in the first round when no candidate earns on the drive and no force alone earns kPartnerMargin
/// on the force channel: the pair of forces whose features together earn most there, when that is kPartnerMargin
/// plus ln of the pairs tried, and each earns kClearMargin beside the other (two forces whose nonlinear parts cancel
/// in part, as Rms(v) rising with the velocity and friction falling with it: alone each is mostly the other's
/// opposite, together their sum is fitted).
std::optional<ForcePair> force_pair_lead(const ForceChannel& channel, const Records& r, const Fit& current,
                                         const std::vector<Candidate>& scored, const std::vector<Effect>& kept);

/// The partner's finding, after the round's `chosen` (nullptr: a force the force channel leads with): its drive-side term is fitted jointly with every term of
/// `current` (the model with `chosen`, replaced by the joint fit when that lowers validation J; else the partner is
/// reported and its term not applied); its word from the force channel's margin over the next-best force,
/// `where` the estimation residual's location, `noise_floor_pct` for the share of J it explains.
Finding partner_finding(const Records& r, const ForcePartner& partner, const Candidate* chosen, Fit& current,
                        const ResidualLocation& where, double noise_floor_pct);

}  // namespace panelbass::models::diagnosis_detail

#include "models/diagnosis/diagnosis_look_alikes.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "models/diagnosis/diagnosis_explanations.h"

namespace panelbass::models::diagnosis_detail {

std::vector<const Candidate*> look_alikes_of(const Candidate& chosen, const std::vector<Candidate>& scored,
                                             const std::function<double(const Candidate&)>& score, bool closed) {
  std::vector<const Candidate*> out;
  std::vector<Effect> group{chosen.effect};
  for (std::size_t reached = 0; reached < group.size() && (closed || reached == 0); ++reached)
    for (const Candidate& c : scored)
      if (look_alike(group[reached], c.effect) && c.effect != chosen.effect && score(c) > 0.0 &&
          std::ranges::find(out, &c) == out.end()) {
        out.push_back(&c);
        if (std::ranges::find(group, c.effect) == group.end()) group.push_back(c.effect);
      }
  return out;
}

const Candidate* decided_by_current(const Candidate* chosen, const std::vector<const Candidate*>& alikes,
                                    const ForceChannel& channel, const Records& r, const Fit& current,
                                    const std::vector<Effect>& kept, nlohmann::json& verdict,
                                    FindingConfidence& confidence) {
  std::vector<const Candidate*> group{chosen};
  group.insert(group.end(), alikes.begin(), alikes.end());
  std::vector<double> scores;
  verdict = nlohmann::json::array();
  for (const Candidate* c : group) {
    const ForceScore f = force_score(channel, r, current, c->effect, kept);
    const bool force = acts_as_force(c->effect) && c->effect != Effect::inductance;
    scores.push_back(force ? f.score : -std::numeric_limits<double>::infinity());
    verdict.push_back({{"effect", to_string(c->effect)}, {"force", force}, {"force_score_bic", f.score},
                       {"J_before_pct", f.j_before_pct}, {"J_after_pct", f.j_after_pct}});
  }
  std::size_t best = 0;
  for (std::size_t k = 1; k < group.size(); ++k)
    if (scores[k] > scores[best]) best = k;
  double second = -std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < group.size(); ++k)
    if (k != best) second = std::max(second, scores[k]);
  const Candidate* pick = nullptr;
  double margin = 0.0;
  std::string why;
  if (scores[best] >= kLikelyMargin) {
    pick = group[best];
    margin = std::isfinite(second) ? scores[best] - std::max(second, 0.0) : scores[best];
    why = "its force on the output explained from the current earns BIC " + fixed(scores[best], 1);
  } else {
    for (const Candidate* c : group)
      if (!acts_as_force(c->effect) || c->effect == Effect::inductance) pick = c;
    if (pick != nullptr) {
      margin = -std::max(scores[best], -1e300);
      margin = std::isfinite(margin) ? std::max(margin, 0.0) + kLikelyMargin : kClearMargin;
      why = "the output explained from the current shows no missing force (the best, " + to_string(group[best]->effect) +
            ", earns BIC " + fixed(scores[best], 1) + "): the effect acts in the electrical loop, which the measured current absorbs";
    } else {
      pick = chosen;
      margin = 0.0;
      why = "no force of the motion earns its parameters on the output explained from the current";
    }
  }
  std::string rivals;
  for (const Candidate* c : group)
    if (c != pick) rivals += (rivals.empty() ? "" : " and ") + to_string(c->effect);
  confidence.runner_up = rivals;
  confidence.runner_up_variant.clear();
  confidence.margin_bic = margin;
  const std::string name = to_string(pick->effect);
  if (margin >= kClearMargin) {
    confidence.word = "clear";
    confidence.sentence = "clear: the current tells " + name + " from its look-alike " + rivals + ": " + why + ".";
  } else if (margin >= kLikelyMargin) {
    confidence.word = "likely";
    confidence.sentence = "likely: the current favours " + name + " over its look-alike " + rivals + ": " + why +
                          ", but not by a margin that settles it.";
  } else {
    confidence.word = "ambiguous";
    confidence.sentence = "ambiguous between " + name + " and " + rivals + ": even with the current, " + why + ".";
  }
  return pick;
}


namespace {

bool is_force(Effect e) { return acts_as_force(e) && e != Effect::inductance; }

// The force of `scored` (not `excluded`, none of `kept`; each with its own term added to `current`) that earns most
// on the force channel with the features of `base` kept, and the next-best; nothing when none has a candidate.
std::optional<ForcePartner> best_force(const ForceChannel& channel, const Records& r, const Fit& current,
                                       const std::vector<Candidate>& scored, const std::vector<Effect>& kept,
                                       const std::vector<Effect>& base, std::optional<Effect> excluded) {
  ForcePartner best;
  double best_score = -std::numeric_limits<double>::infinity();
  best.scores = nlohmann::json::array();
  for (const Candidate& c : scored) {
    if (!is_force(c.effect) || c.effect == excluded || std::ranges::find(kept, c.effect) != kept.end()) continue;
    // Its own term added to `current` (not a linear refit, whose dynamics the other terms do not act through).
    if (c.fit.model.terms.size() != current.model.terms.size() + 1 || c.fit.model.terms.back().effect != c.effect) continue;
    const ForceScore s = force_score(channel, r, current, c.effect, base);
    best.scores.push_back({{"effect", to_string(c.effect)}, {"force_score_bic", s.score}, {"J_before_pct", s.j_before_pct},
                           {"J_after_pct", s.j_after_pct}});
    if (s.score > best_score) {
      if (best.candidate != nullptr) best.runner_up = to_string(best.candidate->effect), best.runner_up_score = best_score;
      best_score = s.score, best.candidate = &c, best.beside = s;
    } else if (best.runner_up.empty() || s.score > best.runner_up_score) {
      best.runner_up = to_string(c.effect), best.runner_up_score = s.score;
    }
  }
  if (best.candidate == nullptr) return std::nullopt;
  return best;
}

}  // namespace

std::optional<ForcePartner> force_partner(const ForceChannel& channel, const Records& r, const Fit& current,
                                          const Candidate& chosen, const std::vector<Candidate>& scored,
                                          const std::vector<Effect>& kept) {
  if (!is_force(chosen.effect)) return std::nullopt;
  std::vector<Effect> with_chosen = kept;
  with_chosen.push_back(chosen.effect);
  std::optional<ForcePartner> best = best_force(channel, r, current, scored, kept, with_chosen, chosen.effect);
  if (!best || best->beside.score < kPartnerMargin) return std::nullopt;
  // Beside a spring's x², a coil offset's x·i earns on the force channel of a concealed asymmetric spring alone (BIC
  // 108–254 on four records of both families, while x² beside x·i earns ≤ 0 on a coil offset alone and 265–540 on
  // the pair): what the spring's force leaves there is not a second effect. The pair is found the other way round.
  if (chosen.effect == Effect::asymmetric_stiffness && best->candidate->effect == Effect::asymmetric_force_factor) return std::nullopt;
  std::vector<Effect> with_partner = kept;
  with_partner.push_back(best->candidate->effect);
  best->chosen_beside = force_score(channel, r, current, chosen.effect, with_partner);
  if (best->chosen_beside.score < kLikelyMargin) return std::nullopt;
  // A look-alike partner must have been far behind on its own: two descriptions of one force that each explain
  // much of it alone are one effect in two shapes (a concealed asymmetric spring, x² 204 and x·i 168 alone, then
  // x·i 211 beside x²), not two effects (a coil offset and a spring: x·i 2139, x² 76 alone, x² 265 beside x·i).
  if (look_alike(chosen.effect, best->candidate->effect)) {
    best->chosen_alone = force_score(channel, r, current, chosen.effect, kept).score;
    best->partner_alone = force_score(channel, r, current, best->candidate->effect, kept).score;
    if (best->chosen_alone < kLookAlikeDominance * std::max(best->partner_alone, 0.0)) return std::nullopt;
  }
  return best;
}

std::optional<ForcePartner> force_lead(const ForceChannel& channel, const Records& r, const Fit& current,
                                       const std::vector<Candidate>& scored, const std::vector<Effect>& kept) {
  std::optional<ForcePartner> best = best_force(channel, r, current, scored, kept, kept, std::nullopt);
  if (!best || best->beside.score < kPartnerMargin) return std::nullopt;
  return best;
}

std::optional<ForcePair> force_pair_lead(const ForceChannel& channel, const Records& r, const Fit& current,
                                         const std::vector<Candidate>& scored, const std::vector<Effect>& kept) {
  std::vector<Effect> forces;
  for (const Candidate& c : scored)
    if (is_force(c.effect) && std::ranges::find(kept, c.effect) == kept.end() && std::ranges::find(forces, c.effect) == forces.end() &&
        c.fit.model.terms.size() == current.model.terms.size() + 1 && c.fit.model.terms.back().effect == c.effect)
      forces.push_back(c.effect);
  const auto with = [&](Effect e) {
    std::vector<Effect> base = kept;
    base.push_back(e);
    return base;
  };
  // The pair's joint BIC: the first alone, then the second beside it (N·ln(J₀/J_ab) − 2p·ln N).
  int tried = 0;
  double best_joint = -std::numeric_limits<double>::infinity();
  std::pair<Effect, Effect> best{};
  for (std::size_t i = 0; i < forces.size(); ++i)
    for (std::size_t j = i + 1; j < forces.size(); ++j) {
      ++tried;
      const double joint = force_score(channel, r, current, forces[i], kept).score +
                           force_score(channel, r, current, forces[j], with(forces[i])).score;
      if (joint > best_joint) best_joint = joint, best = {forces[i], forces[j]};
    }
  if (tried == 0 || best_joint < kPartnerMargin + std::log(static_cast<double>(tried))) return std::nullopt;
  ForcePair out;
  out.joint_score = best_joint;
  out.pairs_tried = tried;
  // Each is the best force beside the other, and earns a clear margin there.
  auto lead = best_force(channel, r, current, scored, kept, with(best.second), best.second);
  auto partner = best_force(channel, r, current, scored, kept, with(best.first), best.first);
  if (!lead || !partner || lead->candidate->effect != best.first || partner->candidate->effect != best.second) return std::nullopt;
  if (lead->beside.score < kClearMargin || partner->beside.score < kClearMargin) return std::nullopt;
  if (partner->beside.score > lead->beside.score) std::swap(lead, partner);  // the stronger beside the other leads
  partner->chosen_beside = lead->beside;
  out.lead = std::move(*lead);
  out.partner = std::move(*partner);
  return out;
}

Finding partner_finding(const Records& r, const ForcePartner& partner, const Candidate* chosen, Fit& current,
                        const ResidualLocation& where, double noise_floor_pct) {
  const Candidate& c = *partner.candidate;
  std::vector<DiagnosisTerm> terms = current.model.terms;
  terms.push_back(c.fit.model.terms.back());
  Fit joint = fit_terms(r, current.model.linear, std::move(terms));
  const bool applied = joint.j_val < current.j_val;
  const std::string name = to_string(c.effect), first = chosen != nullptr ? to_string(chosen->effect) : "";
  Finding f;
  f.effect = c.effect;
  f.added_parameters = applied ? c.parameters : 0;
  f.j_val_before_pct = current.j_val;
  f.j_val_after_pct = applied ? joint.j_val : current.j_val;
  const double correlation = applied ? added_correlation(r, current, joint) : 0.0;
  const std::string where_found = chosen != nullptr ? " beside " + first : " where the drive's candidates earn nothing";
  f.explanation = explain(c, where, correlation) + " Found" + where_found +
                  " by the output explained from the measured current, where its force earns BIC " + fixed(partner.beside.score, 1) +
                  (applied ? "." : "; its term through the drive's dynamics does not lower validation J" +
                                       (chosen != nullptr ? " beside " + first + " (the two are alike there)" : std::string()) +
                                       ", so it is not applied.");
  const double margin = partner.runner_up.empty() ? partner.beside.score : partner.beside.score - std::max(partner.runner_up_score, 0.0);
  const std::string word = margin >= kClearMargin ? "clear" : margin >= kLikelyMargin ? "likely" : "ambiguous";
  const std::string sentence =
      (word == "ambiguous" ? "ambiguous between " + name + " and " + partner.runner_up : word) + ":" +
      (chosen != nullptr ? " beside " + first + "," : "") + " the output explained from the current lacks " + name + "'s force (BIC " +
      fixed(partner.beside.score, 1) +
      (partner.runner_up.empty() ? "" : ", the next " + partner.runner_up + " " + fixed(partner.runner_up_score, 1)) + ")" +
      (chosen != nullptr ? ", and " + first + "'s own still earns " + fixed(partner.chosen_beside.score, 1) + " beside it." : ".");
  const double excess = f.j_val_before_pct - noise_floor_pct;
  f.confidence = {{"word", word},
                  {"runner_up", word == "ambiguous" ? nlohmann::json(partner.runner_up) : nlohmann::json(nullptr)},
                  {"runner_up_variant", nullptr},
                  {"margin_bic", margin},
                  {"explained_share", excess > 0.0 ? std::min(1.0, (f.j_val_before_pct - f.j_val_after_pct) / excess) : 0.0},
                  {"joint_with", chosen != nullptr ? nlohmann::json(first) : nlohmann::json(nullptr)},
                  {"sentence", sentence}};
  f.evidence = {{"joint_with", chosen != nullptr ? nlohmann::json(first) : nlohmann::json(nullptr)},
                {"found_by", "force channel"},
                {"term_applied", applied},
                {"J_val_with_term_pct", joint.j_val},
                {"force_channel",
                 {{"score_bic", partner.beside.score}, {"J_before_pct", partner.beside.j_before_pct},
                  {"J_after_pct", partner.beside.j_after_pct}, {"first_beside_it_bic", partner.chosen_beside.score},
                  {"first_alone_bic", partner.chosen_alone}, {"alone_bic", partner.partner_alone},
                  {"scores", partner.scores}}}};
  f.parameters = c.parameters_json;
  f.parameters["added"] = f.added_parameters;
  if (applied) {
    current = std::move(joint);
    f.parameters["terms"] = terms_json(current.model);
  }
  return f;
}

}  // namespace panelbass::models::diagnosis_detail

#include "models/diagnosis/diagnosis_confidence.h"

#include <algorithm>
#include <cmath>

#include "models/diagnosis/diagnosis.h"

namespace panelbass::models::diagnosis_detail {

FindingConfidence judge_finding(const Candidate& chosen, const std::vector<Candidate>& scored, double j_before,
                                double effective_samples, double noise_floor_pct) {
  // The BIC of a candidate against the round's start, N_eff·ln(J_before/J) − p·ln(N_eff): the validation
  // residual is coloured, so its effective samples stand for N (a margin on N would claim too much).
  const double n = std::max(effective_samples, 2.0);
  const auto bic = [&](const Candidate& c) { return n * std::log(j_before / c.fit.j_val) - c.parameters * std::log(n); };
  FindingConfidence out;
  const Candidate* runner_up = nullptr;
  for (const Candidate& c : scored)
    if (c.effect != chosen.effect && (runner_up == nullptr || bic(c) > bic(*runner_up))) runner_up = &c;
  const double chosen_bic = bic(chosen);
  // A runner-up that does not earn its parameters is no rival: the margin is then the finding's own BIC.
  const bool rival = runner_up != nullptr && bic(*runner_up) > 0.0;
  out.margin_bic = rival ? chosen_bic - bic(*runner_up) : chosen_bic;
  if (rival) {
    out.runner_up = to_string(runner_up->effect);
    out.runner_up_variant = runner_up->variant;
  }
  const double excess = j_before - noise_floor_pct;
  const double drop = j_before - chosen.fit.j_val;
  out.explained_share = excess > 0.0 ? std::min(1.0, drop / excess) : 1.0;
  const std::string name = to_string(chosen.effect);
  if (out.margin_bic >= kClearMargin) {
    out.word = "clear";
    out.sentence = "clear: " + name + (rival ? " fits better than the runner-up, " + out.runner_up : " is the only candidate that earns its parameters") +
                   " (BIC margin " + fixed(out.margin_bic, 1) + ")";
  } else if (out.margin_bic >= kLikelyMargin) {
    out.word = "likely";
    out.sentence = "likely: " + name + " fits better than " + (rival ? out.runner_up : "nothing at all") + " (BIC margin " +
                   fixed(out.margin_bic, 1) + "), but not by a margin that settles it";
  } else {
    out.word = "ambiguous";
    out.sentence = rival ? "ambiguous between " + name + " and " + out.runner_up +
                               ": the data cannot tell them apart (BIC margin " + fixed(out.margin_bic, 1) + ")"
                         : "ambiguous between " + name + " and no effect: on the residual's " + fixed(n, 0) +
                               " effective samples it does not earn its parameters (BIC " + fixed(out.margin_bic, 1) + ")";
  }
  out.sentence += "; it explains " + fixed(100.0 * out.explained_share, 0) + " % of J above the noise floor.";
  return out;
}

nlohmann::json confidence_to_json(const FindingConfidence& c) {
  return {{"word", c.word},
          {"runner_up", c.runner_up.empty() ? nlohmann::json(nullptr) : nlohmann::json(c.runner_up)},
          {"runner_up_variant", c.runner_up_variant.empty() ? nlohmann::json(nullptr) : nlohmann::json(c.runner_up_variant)},
          {"margin_bic", c.margin_bic},
          {"explained_share", c.explained_share},
          {"sentence", c.sentence}};
}

void note_not_excluded(Finding& f, const std::vector<EarnedAlone>& earned, const std::vector<Candidate>& scored,
                       const std::function<double(const Candidate&)>& score, const std::vector<Effect>& kept) {
  nlohmann::json absorbed = nlohmann::json::array();
  std::vector<std::string> names;
  std::string said;
  for (const EarnedAlone& e : earned) {
    if (e.effect == f.effect || std::find(kept.begin(), kept.end(), e.effect) != kept.end()) continue;
    const auto c = std::find_if(scored.begin(), scored.end(), [&](const Candidate& s) { return s.effect == e.effect; });
    if (c == scored.end()) continue;
    const double beside = score(*c);
    if (beside > 0.0) continue;  // it still earns: a later round judges it
    names.push_back(to_string(e.effect));
    absorbed.push_back({{"effect", to_string(e.effect)}, {"score_alone", e.score_alone}, {"score_beside", beside}});
    said += (said.empty() ? "" : ", ") + to_string(e.effect) + " (BIC " + fixed(e.score_alone, 0) + " alone, " + fixed(beside, 0) + " beside it)";
  }
  if (names.empty()) return;
  f.evidence["not_excluded"] = absorbed;
  f.confidence["not_excluded"] = names;
  f.confidence["sentence"] = f.confidence.value("sentence", "") + " Not excluded beside it: " + said +
                             " — its term takes in their shape, so the drive cannot tell whether they are there too.";
}

nlohmann::json unexplained_residual(double j_val_pct, double noise_floor_pct, const ResidualLocation& after) {
  if (at_noise_floor(j_val_pct, noise_floor_pct)) return nullptr;
  const double excess_share = noise_floor_pct > 0.0 ? std::max(0.0, 1.0 - noise_floor_pct / j_val_pct) : 1.0;
  std::vector<std::string> where;
  nlohmann::json located = nlohmann::json::object();
  if (after.peak_significant) {
    where.push_back("in frequency: the residual spectrum peaks at " + fixed(after.peak_frequency_hz, 0) + " Hz (" +
                    fixed(after.peak_over_noise, 1) + " times the noise)");
    located["frequency_hz"] = after.peak_frequency_hz;
  }
  // Level: the residual's rms at large |u| over that at small (1: it ignores the level).
  if (after.level_ratio > 1.5 || after.level_ratio < 1.0 / 1.5) {
    where.push_back("in level: " + fixed(after.level_ratio, 1) + " times the rms at high input level as at low");
    located["input_level_ratio"] = after.level_ratio;
  }
  const StateProfile* state = nullptr;
  for (const StateProfile& s : after.states)
    if (s.shape_significant && (state == nullptr || s.shape_chi2 > state->shape_chi2)) state = &s;
  if (state != nullptr) {
    where.push_back("in state: its mean follows the " + state->state + " (χ²/dof " + fixed(state->shape_chi2, 1) + ")");
    located["state"] = state->state;
    located["state_chi2"] = state->shape_chi2;
  }
  if (after.change_significant) {
    where.push_back("in time: its level changes " + fixed(after.change_ratio, 2) + "× at " + fixed(after.change_time_s, 2) + " s");
    located["change_time_s"] = after.change_time_s;
  }
  std::string sentence = "Unexplained: " + fixed(100.0 * excess_share, 0) + " % of the validation J (" + fixed(j_val_pct, 3) +
                         " % against a noise floor of " + fixed(noise_floor_pct, 3) + " %) is neither noise nor any effect " +
                         "of the vocabulary that earns its parameters";
  if (where.empty()) {
    sentence += "; it has no single place: not one frequency, level, state or time.";
  } else {
    sentence += "; it lies ";
    for (std::size_t i = 0; i < where.size(); ++i) sentence += (i ? "; " : "") + where[i];
    sentence += ".";
  }
  return {{"J_val_pct", j_val_pct}, {"noise_floor_pct", noise_floor_pct}, {"share_of_J", excess_share},
          {"where", located}, {"sentence", sentence}};
}

}  // namespace panelbass::models::diagnosis_detail

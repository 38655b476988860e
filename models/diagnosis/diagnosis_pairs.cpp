#include "models/diagnosis/diagnosis_pairs.h"

#include <algorithm>
#include <cmath>

#include "models/diagnosis/diagnosis_confidence.h"
#include "models/diagnosis/diagnosis_current.h"
#include "models/diagnosis/diagnosis_explanations.h"

namespace panelbass::models::diagnosis_detail {
namespace {

// Whether `c` adds one gray-box term to `current`, through the same linear part (a linear refit moves the
// dynamics the other terms act through, so it is not paired).
bool adds_one_term(const Candidate& c, const Fit& current) {
  const LinearModel &a = c.fit.model.linear, &b = current.model.linear;
  return c.fit.model.terms.size() == current.model.terms.size() + 1 && a.tf.nk == b.tf.nk &&
         a.tf.a.size() == b.tf.a.size() && a.tf.b.size() == b.tf.b.size() && a.tf.a == b.tf.a && a.tf.b == b.tf.b;
}

}  // namespace

std::optional<JointPair> best_joint_pair(const Records& r, const Fit& current, const std::vector<Candidate>& scored,
                                         double best_single_score, double n_val,
                                         const std::function<Eigen::VectorXd(const AugmentedModel&)>& residual) {
  const auto score = [&](double j_val, int parameters) {
    return bic_score(current.j_val, j_val, parameters, n_val);
  };
  std::vector<const Candidate*> leading;
  for (const Candidate& c : scored)
    if (adds_one_term(c, current)) leading.push_back(&c);
  std::sort(leading.begin(), leading.end(), [&](const Candidate* a, const Candidate* b) {
    return score(a->fit.j_val, a->parameters) > score(b->fit.j_val, b->parameters);
  });
  if (leading.size() > static_cast<std::size_t>(kPairedEffects)) leading.resize(kPairedEffects);
  std::optional<JointPair> best;
  double best_score = best_single_score;
  int tried = 0;
  std::vector<JointPair> fitted;
  for (std::size_t i = 0; i < leading.size(); ++i)
    for (std::size_t j = i + 1; j < leading.size(); ++j) {
      const Candidate *a = leading[i], *b = leading[j];
      // Look-alikes are not paired: on one effect the two terms together fit its shape better than either alone, so
      // both "earn" (a visible asymmetric spring came out as a coil offset and a spring, both clear); the rounds and
      // the current's force channel tell them apart instead.
      if (look_alike(a->effect, b->effect)) continue;
      std::vector<DiagnosisTerm> terms = current.model.terms;
      terms.push_back(a->fit.model.terms.back());
      terms.push_back(b->fit.model.terms.back());
      JointPair p;
      p.first = a, p.second = b;
      p.fit = fit_terms(r, current.model.linear, std::move(terms));
      p.parameters = a->parameters + b->parameters;
      ++tried;
      if (score(p.fit.j_val, p.parameters) > best_score) best_score = score(p.fit.j_val, p.parameters), best = std::move(p);
    }
  if (!best) return std::nullopt;
  best->tried = tried;
  // Each member earns its place beside the other, at a threshold shared over the pairs tried.
  const Eigen::VectorXd joint = residual(best->fit.model);
  best->second_given_first = validation_gain(residual(best->first->fit.model), joint, tried);
  best->first_given_second = validation_gain(residual(best->second->fit.model), joint, tried);
  if (!best->second_given_first.significant || !best->first_given_second.significant) return std::nullopt;
  return best;
}

std::vector<Finding> pair_findings(const Records& r, const JointPair& pair, const Fit& current, double effective_samples,
                                   const ResidualLocation& where, bool with_current) {
  const auto needs_current = [&](const Candidate& c) {
    return !with_current && (c.effect == Effect::nonlinear_damping || c.effect == Effect::asymmetric_force_factor);
  };
  const double n = std::max(effective_samples, 2.0);
  std::vector<Finding> out;
  const auto one = [&](const Candidate& c, const Candidate& partner, const Fit& before, const Fit& after,
                       const ValidationGain& beside) {
    Finding f;
    f.effect = c.effect;
    f.added_parameters = c.parameters;
    f.j_val_before_pct = before.j_val;
    f.j_val_after_pct = after.j_val;
    const double correlation = added_correlation(r, current, c.fit);
    f.explanation = explain(c, where, correlation) + " Found jointly with " + to_string(partner.effect) + ".";
    // Its margin beside the partner: the pair against the partner alone, on the effective samples.
    const double margin = n * std::log(partner.fit.j_val / pair.fit.j_val) - c.parameters * std::log(n);
    const bool alike = needs_current(c);
    const std::string word = alike ? "ambiguous" : margin >= kClearMargin ? "clear" : margin >= kLikelyMargin ? "likely" : "ambiguous";
    const std::string name = to_string(c.effect), other = to_string(partner.effect);
    const std::string sentence =
        (alike ? "ambiguous between " + name + " and more of " + other + ": from the drive " + name +
                     " has no signature of its own (a record with the coil current tells them apart)"
               : word == "ambiguous" ? "ambiguous between " + name + " beside " + other + " and " + other + " alone" : word) +
        ": found jointly with " + other + "; added to it, " + name + " lowers validation J from " + fixed(partner.fit.j_val, 4) +
        " to " + fixed(pair.fit.j_val, 4) + " % (z " + fixed(beside.z, 1) + " against " + fixed(beside.threshold, 1) +
        ", BIC margin " + fixed(margin, 1) + " on the residual's " + fixed(n, 0) + " effective samples).";
    f.confidence = {{"word", word}, {"runner_up", word == "ambiguous" ? nlohmann::json(other) : nlohmann::json(nullptr)},
                    {"runner_up_variant", nullptr}, {"margin_bic", margin},
                    {"explained_share", nullptr}, {"joint_with", other}, {"sentence", sentence}};
    f.evidence = {{"added_correlation", correlation},
                  {"J_est_before_pct", before.j_est},
                  {"J_est_after_pct", after.j_est},
                  {"joint_with", other},
                  {"validation_test", validation_gain_to_json(beside)}};
    f.parameters = c.parameters_json;
    f.parameters["added"] = c.parameters;
    f.parameters["terms"] = terms_json(after.model);
    out.push_back(std::move(f));
  };
  // The member the drive can name comes first.
  const bool swap = needs_current(*pair.first) && !needs_current(*pair.second);
  const Candidate& first = swap ? *pair.second : *pair.first;
  const Candidate& second = swap ? *pair.first : *pair.second;
  one(first, second, current, first.fit, swap ? pair.second_given_first : pair.first_given_second);
  one(second, first, first.fit, pair.fit, swap ? pair.first_given_second : pair.second_given_first);
  return out;
}

}  // namespace panelbass::models::diagnosis_detail

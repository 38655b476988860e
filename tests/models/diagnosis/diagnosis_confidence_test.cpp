// judge_finding() and unexplained_residual(): the runner-up is the best candidate of *another* effect, the
// margin is the BIC difference on the effective samples written out from its definition, the word follows
// Kass and Raftery's thresholds, and what is left above the noise floor is reported with where it lies.

#include "models/diagnosis/diagnosis_confidence.h"
#include "tests/support/text.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace panelbass::models::diagnosis_detail {
namespace {

Candidate candidate(Effect effect, const std::string& variant, int parameters, double j_val) {
  Candidate c;
  c.effect = effect;
  c.variant = variant;
  c.parameters = parameters;
  c.fit.j_val = j_val;
  return c;
}

using testing_support::contains;

TEST(DiagnosisConfidence, TheRunnerUpIsTheBestOfAnotherEffectAndTheMarginIsTheirBicDifference) {
  const double n = 400.0, j0 = 2.0;
  const std::vector<Candidate> scored = {candidate(Effect::cubic_stiffness, "output", 1, 1.0),
                                         candidate(Effect::cubic_stiffness, "integral", 1, 1.01),  // same effect: no rival
                                         candidate(Effect::force_factor, "output", 2, 1.1),
                                         candidate(Effect::saturation, "knee", 1, 1.5)};
  const FindingConfidence c = judge_finding(scored[0], scored, j0, n, 0.5);
  EXPECT_EQ(c.runner_up, "force_factor");
  EXPECT_EQ(c.runner_up_variant, "output");
  // BIC = N ln(J0/J) − p ln N, each against the round's start.
  const double expected = (n * std::log(j0 / 1.0) - std::log(n)) - (n * std::log(j0 / 1.1) - 2.0 * std::log(n));
  EXPECT_NEAR(c.margin_bic, expected, 1e-9);
  EXPECT_EQ(c.word, "clear");  // ≈ 44
  EXPECT_NEAR(c.explained_share, (2.0 - 1.0) / (2.0 - 0.5), 1e-12);
  EXPECT_TRUE(contains(c.sentence, "clear: cubic_stiffness fits better than the runner-up, force_factor")) << c.sentence;
}

TEST(DiagnosisConfidence, CloseRivalsAreAmbiguousAndAModestMarginIsLikely) {
  const double n = 1000.0, j0 = 2.0;
  // Equal parameters: the margin is N ln(J_runner/J_best).
  const auto margin_for = [&](double j_runner) {
    const std::vector<Candidate> scored = {candidate(Effect::inductance, "input", 1, 1.0),
                                           candidate(Effect::asymmetric_stiffness, "output", 1, j_runner)};
    return judge_finding(scored[0], scored, j0, n, 0.0);
  };
  const FindingConfidence tie = margin_for(1.0005);  // margin 0.5
  EXPECT_EQ(tie.word, "ambiguous");
  EXPECT_TRUE(contains(tie.sentence, "ambiguous between inductance and asymmetric_stiffness")) << tie.sentence;
  EXPECT_EQ(margin_for(std::exp(5.0 / n)).word, "likely");   // margin 5
  EXPECT_EQ(margin_for(std::exp(12.0 / n)).word, "clear");   // margin 12
}

TEST(DiagnosisConfidence, AFindingThatDoesNotEarnItsParametersOnTheEffectiveSamplesHasNoRival) {
  // On 50 effective samples a 1 % drop in J is worth 50·ln(1/0.99) ≈ 0.5, less than one parameter's ln 50.
  const std::vector<Candidate> scored = {candidate(Effect::saturation, "knee", 1, 0.99)};
  const FindingConfidence c = judge_finding(scored[0], scored, 1.0, 50.0, 0.2);
  EXPECT_TRUE(c.runner_up.empty());
  EXPECT_NEAR(c.margin_bic, 50.0 * std::log(1.0 / 0.99) - std::log(50.0), 1e-9);
  EXPECT_EQ(c.word, "ambiguous");
  EXPECT_TRUE(contains(c.sentence, "and no effect")) << c.sentence;
}

TEST(DiagnosisConfidence, WhatIsLeftAboveTheFloorIsUnexplainedWithWhereItLies) {
  ResidualLocation after;
  EXPECT_TRUE(unexplained_residual(1.05, 1.0, after).is_null()) << "at the floor: nothing unexplained";
  after.peak_significant = true;
  after.peak_frequency_hz = 152.0;
  after.peak_over_noise = 40.0;
  after.level_ratio = 1.02;  // no level dependence: not reported
  StateProfile s;
  s.state = "integral";
  s.shape_chi2 = 3.6;
  s.shape_significant = true;
  after.states.push_back(s);
  const nlohmann::json u = unexplained_residual(2.0, 0.5, after);
  ASSERT_FALSE(u.is_null());
  EXPECT_NEAR(u["share_of_J"].get<double>(), 0.75, 1e-12);  // 1 − floor / J
  EXPECT_EQ(u["where"]["frequency_hz"].get<double>(), 152.0);
  EXPECT_EQ(u["where"]["state"].get<std::string>(), "integral");
  EXPECT_FALSE(u["where"].contains("input_level_ratio"));
  const std::string sentence = u["sentence"].get<std::string>();
  EXPECT_TRUE(contains(sentence, "152 Hz") && contains(sentence, "follows the integral")) << sentence;
}

// An effect that earned alone in the finding's round and earns nothing beside it in the next is one the finding's
// term took in (Bl(x²)'s x²·u holds a cubic spring's x³): listed as not excluded, with both scores; one that still
// earns (a later round judges it), the finding's own effect and one kept since are not.
TEST(DiagnosisConfidence, WhatEarnedAloneAndNothingBesideTheFindingIsNotExcluded) {
  Finding f;
  f.effect = Effect::force_factor;
  f.confidence = {{"word", "clear"}, {"sentence", "clear: force_factor."}};
  const std::vector<EarnedAlone> earned = {{Effect::force_factor, 947.0}, {Effect::cubic_stiffness, 744.0},
                                           {Effect::hysteresis, 177.0}, {Effect::delay, 30.0}, {Effect::nonlinear_damping, 459.0}};
  // The next round starts at J 1.0; BIC = N ln(1/J) − p ln N with N = 1000 here.
  const double n = 1000.0;
  const auto score = [&](const Candidate& c) { return n * std::log(1.0 / c.fit.j_val) - c.parameters * std::log(n); };
  const std::vector<Candidate> next = {candidate(Effect::cubic_stiffness, "x", 8, 1.0),      // −8 ln N: taken in
                                       candidate(Effect::hysteresis, "x", 8, 0.9),           // still earns
                                       candidate(Effect::nonlinear_damping, "x", 8, 0.999)};  // kept since
  note_not_excluded(f, earned, next, score, {Effect::force_factor, Effect::nonlinear_damping});
  ASSERT_TRUE(f.confidence.contains("not_excluded")) << f.confidence.dump(1);
  EXPECT_EQ(f.confidence["not_excluded"], nlohmann::json::array({"cubic_stiffness"}));  // delay: not offered again
  EXPECT_EQ(f.confidence["word"], "clear");  // the word is the finding's own
  ASSERT_EQ(f.evidence["not_excluded"].size(), 1u);
  EXPECT_DOUBLE_EQ(f.evidence["not_excluded"][0]["score_alone"].get<double>(), 744.0);
  EXPECT_NEAR(f.evidence["not_excluded"][0]["score_beside"].get<double>(), -8.0 * std::log(n), 1e-9);
  EXPECT_TRUE(contains(f.confidence["sentence"].get<std::string>(), "Not excluded beside it: cubic_stiffness (BIC 744 alone"))
      << f.confidence["sentence"];
}

}  // namespace
}  // namespace panelbass::models::diagnosis_detail

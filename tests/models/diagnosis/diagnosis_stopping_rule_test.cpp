// The stopping rule on whole diagnoses (issue 58): the linear plant at its noise gives no finding on at least
// 19 of 20 seeds; what follows a right finding is never a spurious "clear"; and records at several drive levels
// tell a nonlinear effect (its gain grows with the level) from a linear mismatch (its gain does not), and a spring
// from a damping (where the main resonance moves).
#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/diagnosis_levels.h"
#include "tests/support/diagnosis_scenarios.h"

#include <gtest/gtest.h>

#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "dsp/excitation.h"
#include "models/linear/linear_identification.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::models {
namespace {

constexpr Eigen::Index kStoppingInit = 50;

// The linear preset identified (OE, the true order 13 and delay 1) from its own record, seed 50.
LinearModel stopping_reference() {
  DiagnosisScenario s = plain_scenario();
  s.baseline = ScenarioBaseline::given_reference;
  return *scenario_baseline(s);
}

DiagnosisOptions single_round() {
  DiagnosisOptions o;
  o.init = kStoppingInit;
  o.output = OutputQuantity::acceleration;  // the virtual transducer's sensor is an accelerometer
  o.max_findings = 1;
  return o;
}

TEST(DiagnosisStoppingRule, TheLinearPlantAtItsNoiseGivesNoFindingOnNineteenSeedsOfTwenty) {
  // Short records (3000 + 2000 samples) keep twenty diagnoses within a test's time; the rule's statistics are
  // computed on whatever length is given. Bonferroni over the candidates at a family-wise 1 % leaves about one
  // spurious finding in a hundred records; 2 of 20 would be far in its tail.
  const LinearModel baseline = stopping_reference();
  int with_findings = 0;
  std::string seen;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const ScenarioRecords r = scenario_records(plain_scenario(), 300 + seed, 3000, 2000);
    const Diagnosis d = diagnose(r.u_est, r.y_est, r.u_val, r.y_val, r.fs, baseline, single_round());
    if (!d.findings.empty()) {
      ++with_findings;
      seen += " seed " + std::to_string(300 + seed) + ": " + to_string(d.findings.front().effect) + " " +
              d.findings.front().evidence["validation_test"].dump();
    }
    // Every stop says why; a diagnosis without findings leaves J as it was.
    EXPECT_TRUE(d.stop.contains("reason")) << d.stop.dump();
  }
  EXPECT_LE(with_findings, 1) << seen;
}

// The first family's inductance at half the bench's length, seed 1: before the stopping rule a right inductance
// (clear) was followed by a spurious `delay` called clear (docs/diagnosis.md, the first family like for like).
TEST(DiagnosisStoppingRule, NoSpuriousClearFindingFollowsTheRightOne) {
  const DiagnosisScenario s = concealed_scenario(Effect::inductance);
  const ScenarioRecords r = scenario_records(s, 1, 30000, 20000);
  DiagnosisOptions o = single_round();
  o.scan_from = 12;  // the linear preset's true order is 13
  o.scan_to = 13;
  o.max_findings = 2;
  const Diagnosis d = diagnose(r.u_est, r.y_est, r.u_val, r.y_val, r.fs, scenario_baseline(s), o);
  ASSERT_FALSE(d.findings.empty()) << d.stop.dump();
  EXPECT_EQ(d.findings.front().effect, Effect::inductance);
  for (std::size_t k = 1; k < d.findings.size(); ++k)
    EXPECT_NE(d.findings[k].confidence["word"].get<std::string>(), "clear")
        << to_string(d.findings[k].effect) << ": " << d.findings[k].confidence.dump(1);
}

struct TwoLevelRecords {
  Eigen::VectorXd u_est, y_est, u_val, y_val;
};

// `plant` driven by uniform noise of peak `level`, split 6000 + 4000.
TwoLevelRecords record_at_level(const PlantConfig& plant, double level, std::uint64_t seed) {
  const Eigen::Index n_est = 6000, n_val = 4000;
  const Eigen::VectorXd u = level * dsp::uniform_noise(static_cast<std::size_t>(n_est + n_val), 1.0, seed);
  const Eigen::VectorXd y = simulate(plant, u, seed + 100).y;
  return {u.head(n_est), y.head(n_est), u.tail(n_val), y.tail(n_val)};
}

// The diagnosis of the loud record, judged on the quiet one too, from `baseline` (nothing: the best OE model of
// the loud record, orders 12 and 13 scanned).
Diagnosis diagnosed_at_two_levels(const PlantConfig& plant, const std::optional<LinearModel>& baseline) {
  const TwoLevelRecords loud = record_at_level(plant, 1.0, 21), quiet = record_at_level(plant, 0.4, 22);
  DiagnosisOptions o = single_round();
  o.scan_from = 12;  // the linear preset's true order is 13
  o.scan_to = 13;
  o.level_name = "loud";
  o.other_levels.push_back({"quiet", quiet.u_val, quiet.y_val});
  return diagnose(loud.u_est, loud.y_est, loud.u_val, loud.y_val, plant.fs, baseline, o);
}

TEST(DiagnosisStoppingRule, AtSeveralLevelsASpringsGainGrowsWithTheDriveAndADelaysDoesNot) {
  // A hardening spring: x³'s share of the output grows as the level to the fourth power. (Against a baseline made
  // without it, the spring also moves the resonance at this level: a linear change first, whose gain is made in
  // loud stretches and lost in quiet ones; the baseline here is the loud record's own linear model.)
  PlantConfig spring = plant_preset("linear");
  spring.nonlinear.stiffness.enabled = true;
  spring.nonlinear.stiffness.k1_per_mm = 0.0;
  spring.nonlinear.stiffness.k2_per_mm2 = 0.06;
  spring.nonlinear.stiffness.scale = 0.3;  // the panel exciter's cubic part at 0.3 of its size (the concealed one is 0.026)
  const Diagnosis nonlinear = diagnosed_at_two_levels(spring, std::nullopt);
  ASSERT_FALSE(nonlinear.findings.empty()) << nonlinear.stop.dump();
  const nlohmann::json& grows = nonlinear.findings.front().evidence["levels"];
  EXPECT_TRUE(grows["judged"].get<bool>()) << grows.dump(1);
  EXPECT_TRUE(grows["grows_with_level"].get<bool>()) << grows.dump(1);
  EXPECT_EQ(grows["records"].size(), 2u);
  // One sample more latency than the baseline knows: the same share of the output is missed at any level.
  PlantConfig late = plant_preset("linear");
  late.converters.delay_samples = 2;
  const Diagnosis linear = diagnosed_at_two_levels(late, stopping_reference());
  ASSERT_FALSE(linear.findings.empty()) << linear.stop.dump();
  // A delay, or on records this short the pole and zero pair that stands in for it: a linear change either way.
  EXPECT_TRUE(diagnosis_detail::is_linear_effect(linear.findings.front().effect)) << to_string(linear.findings.front().effect);
  const nlohmann::json& flat = linear.findings.front().evidence["levels"];
  EXPECT_TRUE(flat["judged"].get<bool>()) << flat.dump(1);
  EXPECT_FALSE(flat["grows_with_level"].get<bool>()) << flat.dump(1);
  EXPECT_TRUE(flat["consistent"].get<bool>()) << flat.dump(1);
}

// `scenario`'s plant driven by uniform noise of peak `level` (seeded by `seed`), `n` samples.
LevelRecord scenario_at_level(const DiagnosisScenario& scenario, double level, std::uint64_t seed, Eigen::Index n,
                              const std::string& name) {
  const Eigen::VectorXd u = level * dsp::uniform_noise(static_cast<std::size_t>(n), 1.0, seed);
  return {name, u, simulate(scenario.plant, u, seed + 100).y};
}

// Where the main resonance moves from half to full drive (20 000 samples at each; the baseline from another loud
// record): a spring that hardens with the level raises its frequency and leaves its decay rate σ = c/2m; Rms(v)
// rising with the velocity raises σ and leaves ω = √(k/m); the linear plant moves neither beyond its uncertainty.
TEST(DiagnosisLevels, TheMainResonanceMovesInFrequencyForASpringAndInDecayForADamping) {
  const auto shift_of = [](const DiagnosisScenario& s) {
    const LevelRecord fit = scenario_at_level(s, 1.0, 30, 20000, "fit");
    LinearIdentificationSpec spec;
    spec.method = LinearMethod::oe;
    spec.order = 13;  // the linear preset's true order
    spec.fs = s.plant.fs;
    spec.init = kStoppingInit;
    const LinearModel baseline = identify_linear(fit.u.head(10000), fit.y.head(10000), fit.u.tail(10000), fit.y.tail(10000), spec).model;
    return diagnosis_detail::resonance_shift(
        baseline, {scenario_at_level(s, 1.0, 31, 20000, "loud"), scenario_at_level(s, 0.5, 32, 20000, "quiet")}, kStoppingInit);
  };
  const diagnosis_detail::ResonanceShift spring = shift_of(concealed_scenario(Effect::cubic_stiffness, 4.0));
  ASSERT_TRUE(spring.judged) << diagnosis_detail::resonance_shift_to_json(spring).dump(1);
  EXPECT_EQ(spring.moves, "frequency") << spring.sentence;
  EXPECT_GT(spring.d_omega, 0.0) << spring.sentence;  // k₂ > 0 hardens
  const diagnosis_detail::ResonanceShift damping = shift_of(concealed_scenario(Effect::nonlinear_damping, 4.0));
  ASSERT_TRUE(damping.judged) << diagnosis_detail::resonance_shift_to_json(damping).dump(1);
  EXPECT_EQ(damping.moves, "decay") << damping.sentence;
  EXPECT_GT(damping.d_sigma, 0.0) << damping.sentence;  // r₂ > 0 damps more at speed
  const diagnosis_detail::ResonanceShift none = shift_of(plain_scenario());
  ASSERT_TRUE(none.judged) << diagnosis_detail::resonance_shift_to_json(none).dump(1);
  EXPECT_EQ(none.moves, "neither") << none.sentence;
}

// The second family's Rms(v) or cubic spring at `size` times its concealed size, 20 000 samples at each of two levels
// (full and half drive), diagnosed from the drive for one round.
Finding diagnosed_with_a_quieter_record(Effect truth, double size) {
  const DiagnosisScenario s = concealed_scenario(truth, size, PlantFamily::second);
  const LevelRecord est = scenario_at_level(s, 1.0, 41, 20000, "estimation"), val = scenario_at_level(s, 1.0, 42, 20000, "loud");
  DiagnosisOptions o = single_round();
  o.scan_from = family_order(s.family) - 1;  // the family's true order and one less
  o.scan_to = family_order(s.family);
  o.level_name = "loud";
  o.other_levels.push_back(scenario_at_level(s, 0.5, 43, 20000, "quiet"));
  const Diagnosis d = diagnose(est.u, est.y, val.u, val.y, s.plant.fs, std::nullopt, o);
  if (d.findings.empty()) throw std::runtime_error("no finding: " + d.stop.dump());
  return d.findings.front();
}

// From the drive a Rms(v) and a cubic spring are both read as x³, ambiguous with each other (near the resonance v³
// is x³ with a phase); a record at half the drive tells them apart by where the main resonance moves. The Rms(v) at
// its concealed size, the spring at twice it: at the concealed size its frequency moves 0.036 Hz on this record
// (z 2.0), which the rule leaves ambiguous — never a damping.
TEST(DiagnosisLevels, ARecordAtHalfTheDriveTellsADampingFromASpringTheDriveCannot) {
  for (const auto& [truth, size] : {std::pair{Effect::nonlinear_damping, 1.0}, std::pair{Effect::cubic_stiffness, 2.0}}) {
    const Finding f = diagnosed_with_a_quieter_record(truth, size);
    const Effect other = truth == Effect::cubic_stiffness ? Effect::nonlinear_damping : Effect::cubic_stiffness;
    EXPECT_EQ(to_string(f.effect), to_string(truth)) << f.confidence.dump(1);
    EXPECT_EQ(f.confidence["runner_up"], to_string(other)) << f.confidence.dump(1);
    EXPECT_EQ(f.confidence["word"], "likely") << f.confidence.dump(1);
    ASSERT_TRUE(f.evidence.contains("resonance_shift")) << f.evidence.dump(1);
    EXPECT_EQ(f.evidence["resonance_shift"]["moves"], truth == Effect::cubic_stiffness ? "frequency" : "decay")
        << f.evidence["resonance_shift"].dump(1);
  }
  const Finding concealed = diagnosed_with_a_quieter_record(Effect::cubic_stiffness, 1.0);
  EXPECT_TRUE(concealed.effect == Effect::cubic_stiffness || concealed.confidence["word"] == "ambiguous") << concealed.confidence.dump(1);
  EXPECT_NE(concealed.evidence["resonance_shift"]["moves"], "decay") << concealed.evidence.dump(1);
}

}  // namespace
}  // namespace panelbass::models

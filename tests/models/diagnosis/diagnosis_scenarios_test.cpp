// Diagnosis on concealed scenarios (tests/support/diagnosis_scenarios.h): for every effect of the vocabulary,
// the `linear` virtual transducer with that effect switched on so small that what the baseline misses
// lies below the sensor noise at every bin of the raw residual spectrum (each test asserts it), found
// from a long record (60 000 + 40 000 samples): the right id comes first and validation J improves.
// Two effects at once are both found; no effect gives no finding over several seeds.
// These runs are the slowest of the models tests (9-36 s each in Release): each diagnosis here is one run
// of the detection bench (bench/diagnosis_detection.sh, every effect over 6 seeds and the effect-free
// scenario over 10), so no scenario is diagnosed twice and only the first round is run where only the first
// finding is asserted. The sanitizer stage leaves them out (scripts/sanitize.sh).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "models/diagnosis/diagnosis.h"
#include "tests/support/diagnosis_scenarios.h"
#include "models/validation/performance.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::models {
namespace {

constexpr Eigen::Index kInit = 50;
constexpr Eigen::Index kEstimation = 60000, kValidation = 40000;

DiagnosisOptions options(int max_findings, PlantFamily family = PlantFamily::panel) {
  DiagnosisOptions o;
  o.init = kInit;
  o.scan_from = family_order(family) - 1;  // the linear preset's true order is 13 (see linear_identification_test.cpp)
  o.scan_to = family_order(family);
  o.output = OutputQuantity::acceleration;  // the virtual transducer's sensor is an accelerometer
  o.max_findings = max_findings;
  return o;
}

struct Diagnosed {
  ScenarioRecords records;
  Diagnosis diagnosis;
};

// The scenario diagnosed from `seed`'s records (n_est + n_val samples), with the coil current when `current`.
Diagnosed diagnose_scenario(const DiagnosisScenario& s, std::uint64_t seed, int max_findings, bool current = false,
                            Eigen::Index n_est = kEstimation, Eigen::Index n_val = kValidation) {
  Diagnosed d{scenario_records(s, seed, n_est, n_val), {}};
  const ScenarioRecords& r = d.records;
  DiagnosisOptions o = options(max_findings, s.family);
  if (current) o.current_est = r.i_est, o.current_val = r.i_val;
  d.diagnosis = diagnose(r.u_est, r.y_est, r.u_val, r.y_val, r.fs, scenario_baseline(s), o);
  return d;
}

bool found(const Diagnosis& d, Effect effect) {
  for (const auto& f : d.findings)
    if (f.effect == effect) return true;
  return false;
}

class ConcealedEffect : public testing::TestWithParam<Effect> {};

TEST_P(ConcealedEffect, IsNamedFirstAndImprovesValidation) {
  const Effect effect = GetParam();
  // One round: the first finding is what is asserted. Concealed inductance's first term closes just under half
  // of the gap to the noise (J 0.00506 against 0.00500 % on seed 1), and a second round the rest.
  const int rounds = effect == Effect::inductance ? 2 : 1;
  const Diagnosed run = diagnose_scenario(concealed_scenario(effect), 1, rounds);
  const Diagnosis& d = run.diagnosis;
  // Concealed: what the baseline misses on the noise-free output lies below the sensor noise everywhere.
  EXPECT_LT(concealment_ratio(run.records, d.baseline_model.linear, kInit), 1.0);
  ASSERT_FALSE(d.findings.empty()) << diagnosis_to_json(d)["rounds"].dump(1);
  const Finding& first = d.findings.front();
  // From the drive alone an effect with a look-alike (a spring's x³ and a damping's v³) may be reported as
  // ambiguous between the two, naming both; otherwise it is named first.
  const bool named_in_ambiguity = first.confidence["word"] == "ambiguous" && first.confidence["runner_up"].is_string() &&
                                  first.confidence["runner_up"].get<std::string>().find(to_string(effect)) != std::string::npos;
  if (!named_in_ambiguity) {
    EXPECT_EQ(to_string(first.effect), to_string(effect)) << first.explanation;
  }
  EXPECT_LT(first.j_val_after_pct, first.j_val_before_pct);
  EXPECT_LT(d.j_val_after_pct, d.j_val_before_pct);
  // What is left is close to the sensor noise: the final J lies nearer the noise's own J than the baseline's.
  // (Saturation: the amplifier clips the drive after the DA filter has smoothed and overshot it, while the
  // term clips the drive as sampled; it closes only about 10 % of the gap, and 5 % is asserted.)
  const double noise_j = j_percent(run.records.y_val_clean, run.records.y_val, kInit);
  const double share = effect == Effect::saturation ? 0.95 : 0.5;
  EXPECT_LT(d.j_val_after_pct - noise_j, share * (d.j_val_before_pct - noise_j)) << "noise alone: " << noise_j << " %";
  EXPECT_FALSE(first.explanation.empty());
  // The fitted parameters of the effects that have a value to compare with the plant's.
  if (effect == Effect::dc_offset) {
    // The sensor offset, 3.5 mV, in raw units: the coefficient times the output scale; its standard error
    // over 40 000 samples of 70 mV noise is 0.35 mV.
    EXPECT_NEAR(d.model.terms.front().coefficients[0] * d.baseline_model.linear.scaling.y_scale, 0.0035, 0.0012);
  } else if (effect == Effect::delay) {
    EXPECT_EQ(first.parameters["nk_before"].get<int>(), 2);
    EXPECT_EQ(first.parameters["nk_after"].get<int>(), 1);  // the converters' true latency
  } else if (effect == Effect::resonance || effect == Effect::antiresonance) {
    // The mode at 450 Hz; the cancelling pair at 440 and 460 Hz dips in between: no resonance of the baseline's there.
    EXPECT_NEAR(first.parameters["frequency_hz"].get<double>(), 450.0, 15.0);
    EXPECT_FALSE(first.parameters["retunes_baseline_resonance"].get<bool>());
  } else if (effect == Effect::creep) {
    // Creep softens the spring below 1/(2πτ) = 16 Hz and, at the 150 Hz main resonance, adds a damping-like change
    // that a pole and zero pair fits by retuning that resonance: the pair is ruled out as an extra mode, so creep
    // is named on its own rather than as ambiguous with a mode.
    EXPECT_EQ(to_string(first.effect), "creep");
    bool mode_ruled_out = false;
    for (const auto& c : d.rounds.front())
      if (c.contains("ruled_out") && (c["effect"] == "resonance" || c["effect"] == "antiresonance"))
        mode_ruled_out = mode_ruled_out ||
                         c["ruled_out"].get<std::string>().find("baseline's own resonance at 150") != std::string::npos;
    EXPECT_TRUE(mode_ruled_out) << d.rounds.front().dump(1);
  }
}

INSTANTIATE_TEST_SUITE_P(DiagnosisScenarios, ConcealedEffect,
                         testing::Values(Effect::resonance, Effect::antiresonance, Effect::delay,
                                         Effect::cubic_stiffness, Effect::asymmetric_stiffness, Effect::force_factor,
                                         Effect::inductance, Effect::hysteresis, Effect::saturation,
                                         Effect::thermal_compression, Effect::dc_offset, Effect::static_nonlinearity,
                                         Effect::creep),
                         [](const testing::TestParamInfo<Effect>& info) { return to_string(info.param); });

// Two effects at once: both are found, each named (at twice the concealed size, from records half as long:
// the same evidence in less time). One test per pair.
class TwoEffects : public testing::TestWithParam<std::pair<Effect, Effect>> {};

TEST_P(TwoEffects, AreBothFound) {
  const auto [a, b] = GetParam();
  const DiagnosisScenario s = combined_scenario(concealed_scenario(a, 2.0), concealed_scenario(b, 2.0));
  const Diagnosis d = diagnose_scenario(s, 2, 3, false, kEstimation / 2, kValidation / 2).diagnosis;
  EXPECT_TRUE(found(d, a)) << diagnosis_to_json(d)["findings"].dump(1);
  EXPECT_TRUE(found(d, b)) << diagnosis_to_json(d)["findings"].dump(1);
  EXPECT_LT(d.j_val_after_pct, d.j_val_before_pct);
}

INSTANTIATE_TEST_SUITE_P(DiagnosisScenarios, TwoEffects,
                         testing::Values(std::pair{Effect::cubic_stiffness, Effect::hysteresis},
                                         std::pair{Effect::resonance, Effect::dc_offset}),
                         [](const testing::TestParamInfo<std::pair<Effect, Effect>>& info) {
                           return to_string(info.param.first) + "_and_" + to_string(info.param.second);
                         });

// Two look-alikes at once with the coil current: a coil offset (x·i) and an asymmetric spring (x²), each at its
// concealed size. The drive's rounds did not add the spring beside the offset (its x² term, through the drive's
// dynamics, is too alike x·u to earn beside it); the output explained from the current lacks its force, so it is
// found in the same round, the second finding saying so.
TEST(DiagnosisScenarios, ACoilOffsetAndAnAsymmetricSpringAreBothFoundWithTheCurrent) {
  const DiagnosisScenario s = combined_scenario(concealed_scenario(Effect::asymmetric_force_factor),
                                                concealed_scenario(Effect::asymmetric_stiffness));
  const Diagnosis d = diagnose_scenario(s, 2, 1, true, kEstimation / 2, kValidation / 2).diagnosis;
  ASSERT_EQ(d.findings.size(), 2u) << diagnosis_to_json(d)["findings"].dump(1);
  EXPECT_EQ(to_string(d.findings[0].effect), "asymmetric_force_factor");
  EXPECT_EQ(to_string(d.findings[1].effect), "asymmetric_stiffness") << d.findings[1].explanation;
  EXPECT_EQ(d.findings[1].evidence["found_by"], "force channel");
  // Its force earns beside the offset's by more than the margin asked, and the offset's still beside it.
  EXPECT_GT(d.findings[1].evidence["force_channel"]["score_bic"].get<double>(), 20.0);
  EXPECT_GT(d.findings[1].evidence["force_channel"]["first_beside_it_bic"].get<double>(), 2.0);
  EXPECT_LT(d.j_val_after_pct, d.j_val_before_pct);
}

// Rms(v) rising with the velocity and friction falling with it: each alone is mostly the other's opposite, so neither
// earns on the drive nor alone on the force channel (a linear damping takes most of their sum); their two forces
// together earn there, each beside the other (first family, seed 2, half length: one round).
TEST(DiagnosisScenarios, RmsOfVelocityAndFrictionAreFoundTogetherOnTheForceChannel) {
  const DiagnosisScenario s = combined_scenario(concealed_scenario(Effect::nonlinear_damping), concealed_scenario(Effect::hysteresis));
  const Diagnosis d = diagnose_scenario(s, 2, 1, true, kEstimation / 2, kValidation / 2).diagnosis;
  ASSERT_EQ(d.findings.size(), 2u) << diagnosis_to_json(d)["findings"].dump(1) << diagnosis_to_json(d)["stop"].dump();
  std::vector<std::string> names{to_string(d.findings[0].effect), to_string(d.findings[1].effect)};
  std::ranges::sort(names);
  EXPECT_EQ(names, (std::vector<std::string>{"hysteresis", "nonlinear_damping"}));
  for (const Finding& f : d.findings) {
    EXPECT_EQ(f.evidence["found_by"], "force channel") << f.explanation;
    // Together they earn more than the margin asked and the pairs tried; each a clear margin beside the other.
    EXPECT_GT(f.evidence["force_channel"]["pair_joint_bic"].get<double>(),
              20.0 + std::log(f.evidence["force_channel"]["pairs_tried"].get<double>()));
    EXPECT_GE(f.evidence["force_channel"]["score_bic"].get<double>(), 10.0);
  }
}

// A cubic spring and Bl(x²) at once from the drive (second family, seed 2, half length; seeds 1–3 are the pairs'
// tuning seeds): Bl(x²)'s term holds x³ (x²·u carries the spring's K·x³ through the drive), so the force factor is
// found and the spring, which earned alone in that round, earns nothing beside it — the report says it is not
// excluded rather than leaving it out. The scores it gives are the rounds' own.
TEST(DiagnosisScenarios, ACubicSpringInsideBlOfXSquaredIsNotExcludedFromTheDrive) {
  const DiagnosisScenario s = combined_scenario(concealed_scenario(Effect::cubic_stiffness, 1.0, PlantFamily::second),
                                                concealed_scenario(Effect::force_factor, 1.0, PlantFamily::second));
  const Diagnosis d = diagnose_scenario(s, 2, 2, false, kEstimation / 2, kValidation / 2).diagnosis;
  ASSERT_FALSE(d.findings.empty()) << diagnosis_to_json(d)["stop"].dump();
  const Finding& f = d.findings.front();
  ASSERT_EQ(to_string(f.effect), "force_factor") << "the case this test is about did not occur";
  ASSERT_TRUE(f.confidence.contains("not_excluded")) << f.confidence.dump(1);
  EXPECT_TRUE(std::ranges::count(f.confidence["not_excluded"], nlohmann::json("cubic_stiffness")) == 1) << f.confidence.dump(1);
  ASSERT_GE(d.rounds.size(), 2u);
  const auto round_score = [&](std::size_t round, const std::string& effect) {
    for (const auto& c : d.rounds[round])
      if (c.contains("score") && c["effect"] == effect) return c["score"].get<double>();
    return std::nan("");
  };
  for (const auto& e : f.evidence["not_excluded"])
    if (e["effect"] == "cubic_stiffness") {
      EXPECT_DOUBLE_EQ(e["score_alone"].get<double>(), round_score(0, "cubic_stiffness"));
      EXPECT_GT(e["score_alone"].get<double>(), 0.0);
      EXPECT_DOUBLE_EQ(e["score_beside"].get<double>(), round_score(1, "cubic_stiffness"));
      EXPECT_LE(e["score_beside"].get<double>(), 0.0);
    }
}

// A concealed asymmetric spring alone, with the current (first family, seed 4, half length, the bench's two rounds):
// the spring first, then a coil offset earns on the drive and the current's verdict favours it — the spring's own
// force in another shape as often as a second effect, so it is called ambiguous, never clear (it was clear before).
TEST(DiagnosisScenarios, ACoilOffsetAfterAnAsymmetricSpringIsNeverCalledClearWithTheCurrent) {
  const Diagnosis d =
      diagnose_scenario(concealed_scenario(Effect::asymmetric_stiffness), 4, 2, true, kEstimation / 2, kValidation / 2).diagnosis;
  ASSERT_EQ(d.findings.size(), 2u) << diagnosis_to_json(d)["findings"].dump(1);
  EXPECT_EQ(to_string(d.findings[0].effect), "asymmetric_stiffness");
  ASSERT_EQ(to_string(d.findings[1].effect), "asymmetric_force_factor") << "the case this test is about did not occur";
  EXPECT_EQ(d.findings[1].confidence["word"], "ambiguous") << d.findings[1].confidence.dump(1);
  EXPECT_EQ(d.findings[1].confidence["runner_up"], "asymmetric_stiffness");
}

// The effects that look alike from the drive: a spring's x³ and a damping's v³ near one resonance, a coil
// offset's x·i and a spring's x² or an inductance's Le(x). With the coil current each is named first, and the
// finding says the current decided; without it, each is named first or reported ambiguous with the right one —
// never named wrong with confidence.
class LookAlikeEffect : public testing::TestWithParam<Effect> {};

TEST_P(LookAlikeEffect, TheCurrentTellsItFromItsLookAlike) {
  const Effect effect = GetParam();
  const Diagnosis d = diagnose_scenario(concealed_scenario(effect), 1, 1, true).diagnosis;
  ASSERT_FALSE(d.findings.empty()) << diagnosis_to_json(d)["rounds"].dump(1);
  EXPECT_EQ(d.channels.back(), "current");
  const Finding& first = d.findings.front();
  EXPECT_EQ(to_string(first.effect), to_string(effect)) << first.confidence.dump(1) << first.evidence["current_channel"].dump(1);
  EXPECT_NE(first.confidence["word"].get<std::string>(), "ambiguous") << first.confidence.dump(1);
  // One effect: the force channel shows no second force beside it (an asymmetric spring's x² and a coil offset's
  // x·i are one force in two shapes, not two effects).
  for (std::size_t k = 1; k < d.findings.size(); ++k)
    EXPECT_NE(d.findings[k].evidence.value("found_by", ""), "force channel") << d.findings[k].explanation;
}

INSTANTIATE_TEST_SUITE_P(DiagnosisScenarios, LookAlikeEffect,
                         testing::Values(Effect::nonlinear_damping, Effect::cubic_stiffness, Effect::asymmetric_force_factor,
                                         Effect::asymmetric_stiffness, Effect::inductance),
                         [](const testing::TestParamInfo<Effect>& info) { return to_string(info.param); });

// Without the current: the look-alikes that are not in ConcealedEffect's list (which asserts as much and more
// for cubic_stiffness, asymmetric_stiffness and inductance on the same records).
class LookAlikeFromTheDrive : public testing::TestWithParam<Effect> {};

TEST_P(LookAlikeFromTheDrive, IsNeverMisnamedWithConfidence) {
  const Effect effect = GetParam();
  const Diagnosis d = diagnose_scenario(concealed_scenario(effect), 1, 1).diagnosis;
  ASSERT_FALSE(d.findings.empty()) << diagnosis_to_json(d)["rounds"].dump(1);
  const Finding& first = d.findings.front();
  if (first.effect != effect) {
    EXPECT_EQ(first.confidence["word"].get<std::string>(), "ambiguous") << first.confidence.dump(1);
    EXPECT_NE(first.confidence["runner_up"].get<std::string>().find(to_string(effect)), std::string::npos)
        << first.confidence.dump(1);
  }
}

INSTANTIATE_TEST_SUITE_P(DiagnosisScenarios, LookAlikeFromTheDrive,
                         testing::Values(Effect::nonlinear_damping, Effect::asymmetric_force_factor),
                         [](const testing::TestParamInfo<Effect>& info) { return to_string(info.param); });

// No effect: no finding, on two seeds (one test each; the detection bench runs ten), and nothing changed.
class NoEffect : public testing::TestWithParam<std::uint64_t> {};

TEST_P(NoEffect, GivesNoFinding) {
  const Diagnosis d = diagnose_scenario(plain_scenario(), GetParam(), 2).diagnosis;
  EXPECT_TRUE(d.findings.empty()) << diagnosis_to_json(d)["findings"].dump(1);
  EXPECT_EQ(d.j_val_after_pct, d.j_val_before_pct);
}

INSTANTIATE_TEST_SUITE_P(DiagnosisScenarios, NoEffect, testing::Values(11u, 12u),
                         [](const testing::TestParamInfo<std::uint64_t>& info) { return "seed" + std::to_string(info.param); });

// A baseline that is not a linear model: the virtual transducer without the effect (no sensor noise) as the
// simulation, the data from the plant with a cubic spring (three times the concealed size). The terms act
// through its linearisation.
TEST(DiagnosisScenarios, PlantBaselineMissingTheCubicSpring) {
  const DiagnosisScenario s = concealed_scenario(Effect::cubic_stiffness, 3.0);
  const ScenarioRecords r = scenario_records(s, 3, kEstimation / 2, kValidation / 2);
  PlantConfig plant = plain_scenario().plant;
  plant.sensor.noise_rms_V = 0.0;
  const SimulationBaseline baseline{"plant", plant.fs, [plant](const Eigen::VectorXd& u, const Eigen::VectorXd&, Eigen::Index) {
                                      return simulate(plant, u, 0).y;
                                    }};
  const Diagnosis d = diagnose(r.u_est, r.y_est, r.u_val, r.y_val, r.fs, baseline, options(3));
  EXPECT_EQ(d.baseline_kind, "plant");
  // The baseline's J is that of the plant itself, not of its linearisation: the noise-free plain plant's
  // output against the data.
  EXPECT_NEAR(d.j_val_before_pct, j_percent(simulate(plant, r.u_val, 0).y, r.y_val, kInit), 1e-9);
  // Against a fixed baseline the hardening spring also raises the resonance at this drive level, so a
  // linear refit of the resonance may come first; the spring must be found.
  EXPECT_TRUE(found(d, Effect::cubic_stiffness)) << diagnosis_to_json(d)["findings"].dump(1);
  EXPECT_LT(d.j_val_after_pct, d.j_val_before_pct);
}

TEST(DiagnosisScenarios, SizeMustBePositive) {
  EXPECT_THROW(concealed_scenario(Effect::cubic_stiffness, 0.0), std::invalid_argument);
  EXPECT_THROW(concealed_scenario(Effect::cubic_stiffness, -1.0), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

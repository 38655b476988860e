// Diagnosis, the pieces and the visible cases: filtering and the residual's location against plain
// computations; visible effects named; a given baseline with a sensor offset or a wrong delay diagnosed
// as such. The concealed scenarios, one per effect, are in diagnosis_scenarios_test.cpp.
#include "models/diagnosis/diagnosis.h"
#include "tests/support/diagnosis_scenarios.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "dsp/excitation.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "tests/support/expect_error.h"
#include "tests/support/linear_systems.h"

namespace panelbass::models {
namespace {

using testing_support::expect_invalid;
using testing_support::gaussian;

constexpr double kFs = 3000.0;

// Uniform white noise at full drive through `plant`, split into estimation and validation records.
ScenarioRecords make_scenario(const PlantConfig& plant, std::uint64_t seed, Eigen::Index n_est, Eigen::Index n_val) {
  DiagnosisScenario s = plain_scenario();
  s.plant = plant;
  return scenario_records(s, seed, n_est, n_val);
}

DiagnosisOptions narrow_scan() {
  // The true linear structure has 13 states (see linear_identification_test.cpp); a narrow scan keeps
  // the test short and still lets the validation data choose.
  DiagnosisOptions o;
  o.scan_from = 12;
  o.scan_to = 13;
  return o;
}

// narrow_scan() for a test that asserts the first finding alone: one augmentation round (each further round
// refits every candidate again, the bulk of a diagnosis's time).
DiagnosisOptions first_finding_only() {
  DiagnosisOptions o = narrow_scan();
  o.max_findings = 1;
  return o;
}

TEST(Diagnosis, FilterThroughIsTheLinearModelsSimulation) {
  TransferFunction tf;
  tf.a = Eigen::Vector2d(-1.5, 0.7);
  tf.b = Eigen::Vector2d(0.5, 0.2);
  tf.nk = 1;
  LinearModel model;
  model.tf = tf;
  model.fs = kFs;
  const Eigen::VectorXd x = gaussian(500, 1.0, 3);
  EXPECT_LT((filter_through(tf, x) - model.simulate(x)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Diagnosis, LocateFindsTheNoiseFloorAnOffsetAndALine) {
  // A residual of white noise (σ = 0.1) on an output of unit power: the noise floor is 1 % by [2A].
  const Eigen::Index n = 20000;
  const Eigen::VectorXd u = gaussian(n, 1.0, 1);
  const Eigen::VectorXd y = gaussian(n, 1.0, 2);
  const Eigen::VectorXd noise = gaussian(n, 0.1, 3);
  const double expected_pct = 100.0 * noise.squaredNorm() / y.squaredNorm();
  const ResidualLocation white = locate_residual(u, y, y - noise, kFs, 0);
  EXPECT_NEAR(white.noise_floor_pct, expected_pct, 0.1 * expected_pct);
  EXPECT_LT(std::abs(white.mean_t), 4.0);
  // An offset of 0.01 (σ/10): the mean is found, tens of standard errors from zero.
  const ResidualLocation offset = locate_residual(u, y, (y - noise).array() - 0.01, kFs, 0);
  EXPECT_NEAR(offset.mean, 0.01 + noise.mean(), 1e-12);
  EXPECT_GT(offset.mean_t, 10.0);
  // A line at 400 Hz with the noise's power: far above the floor, at its frequency.
  Eigen::VectorXd line = noise;
  for (Eigen::Index k = 0; k < n; ++k) line[k] += 0.1 * std::sqrt(2.0) * std::sin(2.0 * std::numbers::pi * 400.0 * k / kFs);
  const ResidualLocation tone = locate_residual(u, y, y - line, kFs, 0);
  EXPECT_NEAR(tone.peak_frequency_hz, 400.0, kFs / 2048.0);
  EXPECT_GT(tone.peak_over_noise, 10.0 * tone.peak_threshold);
  expect_invalid([&] { locate_residual(u.head(100), y.head(100), y.head(100), kFs, 0); }, "256");
}

// Not concealed (their residual peaks 8–15 times the noise near the main resonance): the even-order
// spring (or its look-alike, reported ambiguous with it) and the clipping amplifier are named first and validation J improves. The gray-box terms explain
// only part of what the baseline misses here (see the report), so only the id and the direction are
// asserted.
TEST(Diagnosis, VisibleAsymmetricStiffnessIsNamedFirst) {
  PlantConfig plant = plant_preset("linear");
  plant.nonlinear.stiffness.enabled = true;
  plant.nonlinear.stiffness.k1_per_mm = 0.03;  // the panel exciter's asymmetry, no cubic part
  plant.nonlinear.stiffness.k2_per_mm2 = 0.0;
  const ScenarioRecords s = make_scenario(plant, 2, 30000, 20000);
  const Diagnosis d = diagnose(s.u_est, s.y_est, s.u_val, s.y_val, kFs, std::nullopt, first_finding_only());
  ASSERT_FALSE(d.findings.empty());
  // From the drive alone a coil offset (x·u) looks like it: the spring is named first, or the finding is
  // ambiguous between the two, naming it (the current tells them apart: diagnosis_scenarios_test.cpp).
  const Finding& first = d.findings[0];
  if (first.effect != Effect::asymmetric_stiffness) {
    EXPECT_EQ(first.confidence["word"], "ambiguous") << first.explanation;
    EXPECT_EQ(first.confidence["runner_up"], "asymmetric_stiffness") << first.confidence.dump(1);
  }
  EXPECT_LT(first.j_val_after_pct, 0.97 * first.j_val_before_pct);
}

TEST(Diagnosis, VisibleClippingIsNamedSaturationFirst) {
  PlantConfig plant = plant_preset("linear");
  plant.nonlinear.clipping.enabled = true;
  plant.nonlinear.clipping.level = 0.8;
  plant.nonlinear.clipping.knee = 0.05;
  const ScenarioRecords s = make_scenario(plant, 2, 30000, 20000);
  const Diagnosis d = diagnose(s.u_est, s.y_est, s.u_val, s.y_val, kFs, std::nullopt, first_finding_only());
  ASSERT_FALSE(d.findings.empty());
  EXPECT_EQ(d.findings[0].effect, Effect::saturation) << d.findings[0].explanation;
  EXPECT_LT(d.findings[0].j_val_after_pct, 0.97 * d.findings[0].j_val_before_pct);
  // The amplifier clips both sides alike: past the knee the fitted slope falls, where it sits (the drive as
  // sampled or behind the drive's filter: the clip acts after the DA filter, before the coil).
  EXPECT_EQ(d.findings[0].parameters.value("shape", ""), "saturating") << d.findings[0].parameters.dump();
  EXPECT_EQ(d.findings[0].parameters.value("position", ""), "input") << d.findings[0].parameters.dump();
}

// The linear preset identified (OE, the true order 13 and delay 1) from its own record, seed 50.
LinearModel reference_baseline() {
  DiagnosisScenario s = plain_scenario();
  s.baseline = ScenarioBaseline::given_reference;
  return *scenario_baseline(s);
}

TEST(Diagnosis, GivenBaselineMissingASensorOffsetGetsADcOffset) {
  PlantConfig plant = plant_preset("linear");
  plant.sensor.offset_V = 0.03;
  const ScenarioRecords s = make_scenario(plant, 7, 20000, 10000);
  const Diagnosis d = diagnose(s.u_est, s.y_est, s.u_val, s.y_val, kFs, reference_baseline(), {});
  ASSERT_FALSE(d.findings.empty());
  EXPECT_EQ(d.findings[0].effect, Effect::dc_offset) << d.findings[0].explanation;
  EXPECT_LT(d.findings[0].j_val_after_pct, d.findings[0].j_val_before_pct);
  // The offset fitted, in raw units, is the sensor's: Σ coefficient · y_scale.
  const DiagnosisTerm& term = d.model.terms.front();
  EXPECT_NEAR(term.coefficients[0] * d.baseline_model.linear.scaling.y_scale, 0.03, 0.003);
  EXPECT_EQ(d.at_noise_floor, d.j_val_after_pct < 1.1 * d.noise_floor_pct)
      << "J " << d.j_val_after_pct << " %, floor " << d.noise_floor_pct << " %";
}

TEST(Diagnosis, GivenBaselineWithTooShortADelayGetsADelay) {
  PlantConfig plant = plant_preset("linear");
  plant.converters.delay_samples = 2;  // one sample more latency than the baseline knows
  const ScenarioRecords s = make_scenario(plant, 8, 20000, 10000);
  DiagnosisOptions one_round;
  one_round.max_findings = 1;  // the first finding alone is asserted
  const Diagnosis d = diagnose(s.u_est, s.y_est, s.u_val, s.y_val, kFs, reference_baseline(), one_round);
  ASSERT_FALSE(d.findings.empty());
  EXPECT_EQ(d.findings[0].effect, Effect::delay) << d.findings[0].explanation;
  EXPECT_EQ(d.findings[0].parameters["nk_after"].get<int>(), 2);
  EXPECT_LT(d.findings[0].j_val_after_pct, 0.5 * d.findings[0].j_val_before_pct);
}

// The README tour's plant: its converters' latency is one sample, the first sample small (their filters).
// The identified baseline starts there; once a nonlinear term is in, trading that small first coefficient
// for one more at the tail (nk + 1) lowers J a little, which is the numerator's length, not a dead time.
// No finding may move the delay away from the converters' latency.
TEST(Diagnosis, APanelExcitersSmallFirstSampleIsNotTakenForDeadTime) {
  const PlantConfig plant = plant_preset("panel-exciter");
  const ScenarioRecords s = make_scenario(plant, 1, 10000, 2000);
  DiagnosisOptions o;
  o.scan_from = 7;
  o.scan_to = 8;
  o.max_findings = 2;
  const Diagnosis d = diagnose(s.u_est, s.y_est, s.u_val, s.y_val, kFs, std::nullopt, o);
  ASSERT_FALSE(d.findings.empty());
  EXPECT_EQ(d.baseline_info["nk"].get<int>(), plant.converters.delay_samples);
  for (const Finding& f : d.findings) {
    if (f.effect != Effect::delay) continue;
    EXPECT_EQ(f.parameters["nk_after"].get<int>(), plant.converters.delay_samples) << f.explanation;
  }
}

// Five periods of a random-odd multisine (4096 samples a period, 10–1200 Hz, amplitude 0.8), seed `seed`.
Eigen::VectorXd odd_multisine(std::uint64_t seed) {
  dsp::MultisineSpec spec;
  spec.period = 4096;
  spec.periods = 5;
  spec.fs = kFs;
  spec.f_min = 10.0;
  spec.lines = dsp::MultisineLines::random_odd;
  spec.amplitude = 0.8;
  spec.seed = seed;
  return dsp::multisine(spec).signal;
}

TEST(Diagnosis, APeriodicMultisineRecordIsIdentifiedAndItsEmptyLinesAreRead) {
  // Five periods of a random-odd multisine (10–1200 Hz) through the linear plant: the input has no power
  // above 1200 Hz (the baseline's delay estimate must not need it), the record is found periodic, and a
  // linear plant puts nothing on the empty lines beyond its noise.
  const PlantConfig plant = plant_preset("linear");
  const Eigen::VectorXd u_est = odd_multisine(1), u_val = odd_multisine(2);
  const Diagnosis d = diagnose(u_est, simulate(plant, u_est, 3).y, u_val, simulate(plant, u_val, 4).y, kFs, std::nullopt,
                               narrow_scan());
  const PeriodicDistortion& p = d.located_val.distortion;
  ASSERT_TRUE(p.periodic);
  EXPECT_EQ(p.period, 4096);
  // After the 50 samples that set the state, four whole periods are left; one settles, three are judged.
  EXPECT_EQ(p.periods, 3);
  EXPECT_TRUE(p.odd_lines_only);
  EXPECT_LT(p.output_even_db, p.threshold_db);
  EXPECT_LT(p.output_odd_db, p.threshold_db);
  EXPECT_LT(d.baseline_j_val_pct, 2.0 * d.noise_floor_pct) << "the linear plant is fitted to its noise";
}

// A symmetric cubic spring driven by an odd random multisine makes odd distortion only: the residual's empty
// even lines hold noise, so an even-order term (an asymmetric spring) is ruled out by the periodic record
// and the spring is named by its odd term.
TEST(Diagnosis, AnOddMultisineRulesOutEvenOrderTermsWhenOnlyOddDistortionIsLeft) {
  PlantConfig plant = plant_preset("linear");
  plant.nonlinear.stiffness.enabled = true;
  plant.nonlinear.stiffness.k1_per_mm = 0.0;   // symmetric: no x² part
  plant.nonlinear.stiffness.k2_per_mm2 = 0.12;
  const Eigen::VectorXd u_est = odd_multisine(1), u_val = odd_multisine(2);
  DiagnosisOptions o = narrow_scan();
  o.max_findings = 1;
  const Diagnosis d = diagnose(u_est, simulate(plant, u_est, 3).y, u_val, simulate(plant, u_val, 4).y, kFs, std::nullopt, o);
  const PeriodicDistortion& p = d.located_val.distortion;
  ASSERT_TRUE(p.periodic && p.odd_lines_only);
  ASSERT_GT(p.residual_odd_db, p.threshold_db) << "the spring's odd distortion is visible";
  ASSERT_LT(p.residual_even_db, p.threshold_db) << "and nothing even";
  ASSERT_FALSE(d.rounds.empty());
  bool even_ruled_out = false;
  for (const auto& c : d.rounds[0]) {
    if (c["effect"] == "asymmetric_stiffness") {
      EXPECT_TRUE(c.contains("ruled_out")) << c.dump();
      even_ruled_out = c.contains("ruled_out");
    }
    if (c["effect"] == "cubic_stiffness") {
      EXPECT_FALSE(c.contains("ruled_out")) << c.dump();
    }
  }
  EXPECT_TRUE(even_ruled_out) << d.rounds[0].dump(1);
  ASSERT_FALSE(d.findings.empty());
  EXPECT_EQ(d.findings[0].effect, Effect::cubic_stiffness) << d.findings[0].explanation;
}

// The final verdict against the margin the web UI hard-coded before it moved here (J under 1.1 × the noise
// floor), written out as a number: a J just below and just above it.
TEST(Diagnosis, AtTheNoiseFloorJustUnderTenPercentAboveItAndNotJustOver) {
  EXPECT_TRUE(at_noise_floor(2.0 * 1.0999, 2.0));
  EXPECT_FALSE(at_noise_floor(2.0 * 1.1001, 2.0));
  EXPECT_TRUE(at_noise_floor(1.5, 2.0)) << "under the floor (an estimate) is at it too";
  EXPECT_FALSE(at_noise_floor(0.0, 0.0)) << "no floor estimated: no verdict of noise";
  Diagnosis d;
  d.j_val_after_pct = 2.1;
  d.noise_floor_pct = 2.0;
  d.at_noise_floor = true;
  EXPECT_TRUE(diagnosis_to_json(d).at("at_noise_floor").get<bool>());
  d.at_noise_floor = false;
  EXPECT_FALSE(diagnosis_to_json(d).at("at_noise_floor").get<bool>());
}

TEST(Diagnosis, BadRecordsAreNamed) {
  const Eigen::VectorXd u = gaussian(2000, 1.0, 1), y = gaussian(2000, 1.0, 2);
  expect_invalid([&] { diagnose(u, y.head(1999), u, y, kFs, std::nullopt); }, "estimation record");
  expect_invalid([&] { diagnose(u, y, u.head(100), y.head(100), kFs, std::nullopt); }, "validation record");
  expect_invalid([&] { diagnose(u, y, u, y, 0.0, std::nullopt); }, "sample rate");
  Eigen::VectorXd bad = y;
  bad[10] = std::nan("");
  expect_invalid([&] { diagnose(u, bad, u, y, kFs, std::nullopt); }, "not finite");
}

TEST(Diagnosis, SimulationBaselineAtAnotherRateOrNotFiniteIsNamed) {
  const Eigen::VectorXd u = gaussian(3000, 1.0, 1), y = gaussian(3000, 1.0, 2);
  const SimulationBaseline slow{"narx", 1000.0, [](const Eigen::VectorXd& x, const Eigen::VectorXd&, Eigen::Index) { return x; }};
  expect_invalid([&] { diagnose(u, y, u, y, kFs, slow); }, "1000");
  const SimulationBaseline broken{"plant", kFs, [](const Eigen::VectorXd& x, const Eigen::VectorXd&, Eigen::Index) {
                                    Eigen::VectorXd out = x;
                                    out[5] = std::nan("");
                                    return out;
                                  }};
  expect_invalid([&] { diagnose(u, y, u, y, kFs, broken); }, "not finite");
  expect_invalid([&] { diagnose(u, y, u, y, kFs, SimulationBaseline{"narx", kFs, {}}); }, "no simulation");
}

TEST(Diagnosis, EffectIdsAreTheVocabulary) {
  // The ids of issue #9, in the order docs/diagnosis.md lists them.
  const std::vector<std::string> expected = {"resonance",  "antiresonance", "delay",      "cubic_stiffness",
                                             "asymmetric_stiffness", "force_factor", "inductance", "hysteresis",
                                             "saturation", "thermal_compression", "dc_offset", "static_nonlinearity",
                                             "nonlinear_damping", "asymmetric_force_factor", "creep"};
  std::vector<std::string> ids;
  for (Effect e : all_effects()) ids.push_back(to_string(e));
  EXPECT_EQ(ids, expected);
  EXPECT_EQ(vocabulary_text().substr(0, 26), "resonance, antiresonance, ");
}

}  // namespace
}  // namespace panelbass::models

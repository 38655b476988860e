// The stopping rule's pieces (issue 58): the normal and t quantiles against tabulated values; the validation
// test passes a removed signal and, over many draws of noise alone, passes about as often as its level says;
// the noise floor from repeated periods is the added noise's, at any distortion, where the residual's top band
// grows with it; and the level verdict reads a gain that grows with the drive as nonlinear.
#include "models/diagnosis/diagnosis_stopping.h"
#include "models/diagnosis/diagnosis_levels.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "models/diagnosis/diagnosis_locate.h"
#include "tests/support/noise.h"

namespace panelbass::models::diagnosis_detail {
namespace {

using testing_support::gaussian;

TEST(DiagnosisStopping, QuantilesAreTheTablesOnes) {
  // Abramowitz and Stegun, tables 26.1 and 26.10.
  EXPECT_NEAR(normal_upper_quantile(0.025), 1.959964, 1e-5);
  EXPECT_NEAR(normal_upper_quantile(1e-4), 3.719016, 1e-5);
  EXPECT_NEAR(normal_upper_quantile(0.5), 0.0, 1e-9);
  EXPECT_NEAR(student_upper_quantile(0.025, 40.0), 2.021075, 2e-3);
  EXPECT_NEAR(student_upper_quantile(0.005, 60.0), 2.660283, 5e-3);
  EXPECT_THROW(normal_upper_quantile(0.0), std::invalid_argument);
}

TEST(DiagnosisStopping, ARemovedSignalPassesAndNoiseAlonePassesAboutAsOftenAsTheLevelSays) {
  const Eigen::Index n = 4000;
  const Eigen::VectorXd noise = gaussian(n, 1.0, 1);
  // A sinusoid with 2 % of the noise's power, removed: each batch of 100 samples gains 0.02 against a spread of
  // 2·√(0.02/100) ≈ 0.028, so about three batches in four gain: far beyond one candidate's threshold (z 2.33).
  Eigen::VectorXd line(n);
  for (Eigen::Index k = 0; k < n; ++k) line[k] = 0.2 * std::sin(2.0 * std::numbers::pi * 0.0731 * static_cast<double>(k));
  const ValidationGain removed = validation_gain(noise + line, noise, 1);
  EXPECT_TRUE(removed.significant) << removed.z << " against " << removed.threshold;
  EXPECT_EQ(removed.batches, 40);
  // The gain is the share of the "before" residual's energy removed: (Σ(w + s)² − Σw²) / Σ(w + s)².
  EXPECT_NEAR(removed.gain, ((noise + line).squaredNorm() - noise.squaredNorm()) / (noise + line).squaredNorm(), 1e-12);
  // The same with 40 candidates tried: the threshold rises to the normal's upper 0.01/40 quantile.
  EXPECT_NEAR(validation_gain(noise + line, noise, 40).threshold, normal_upper_quantile(kFamilyLevel / 40.0), 1e-12);
  // A gain made in a few stretches only (a peak's worth in 3 batches of 40) is not consistent, however large.
  Eigen::VectorXd burst = Eigen::VectorXd::Zero(n);
  burst.segment(1000, 300) = 3.0 * gaussian(300, 1.0, 7);
  EXPECT_FALSE(validation_gain(noise + burst, noise, 40).significant);
  // Noise alone: "after" subtracts a term fitted to other noise (the gain's sign is chance). Over 400 draws at one
  // candidate's level (1 %) the passes are few: a binomial(400, 0.01) exceeds 12 with probability < 0.1 %.
  int passes = 0;
  for (std::uint64_t seed = 0; seed < 400; ++seed) {
    const Eigen::VectorXd e = gaussian(n, 1.0, 1000 + seed);
    const Eigen::VectorXd fitted_to_other_noise = 0.05 * gaussian(n, 1.0, 5000 + seed);
    passes += validation_gain(e, e - fitted_to_other_noise, 1).significant ? 1 : 0;
  }
  EXPECT_LE(passes, 12);
  EXPECT_THROW(validation_gain(noise.head(199), noise.head(199), 1), std::invalid_argument);  // 20 batches of 10 at least
}

TEST(DiagnosisStopping, TheFloorFromRepeatedPeriodsIsTheNoisesAtAnyDistortionWhereTheTopBandGrows) {
  // Eight periods of 1024 samples of one noise drive through a resonance-free low-pass, its cube added, and
  // sensor noise σ = 0.02: the floor is the noise's share of Σy² however large the distortion.
  const Eigen::Index period = 1024, periods = 8, n = period * periods, init = 50;
  const Eigen::VectorXd block = gaussian(period, 0.5, 3);
  Eigen::VectorXd u(n);
  for (Eigen::Index p = 0; p < periods; ++p) u.segment(p * period, period) = block;
  Eigen::VectorXd linear(n);
  double state = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) linear[k] = state = 0.7 * state + 0.3 * u[k];
  const Eigen::VectorXd noise = gaussian(n, 0.02, 4);
  double previous_top_band = 0.0;
  for (const double cube : {0.0, 2.0, 6.0}) {
    const Eigen::VectorXd clean = linear.array() + cube * linear.array().cube();
    const Eigen::VectorXd y = clean + noise;
    const auto floor = periodic_noise_floor(u, y, init);
    ASSERT_TRUE(floor.has_value());
    EXPECT_EQ(floor->source, FloorSource::repeated_periods);
    const double expected = 100.0 * noise.tail(n - init).squaredNorm() / y.tail(n - init).squaredNorm();
    EXPECT_NEAR(floor->pct, expected, 3.0 * floor->relative_sd * expected) << "cube " << cube;
    // The top band of a linear model's residual (here the linear part itself) carries the distortion too.
    const ResidualLocation top = locate_residual(u, y, linear, 3000.0, init);
    EXPECT_GT(top.noise_floor_pct, previous_top_band) << "cube " << cube;
    previous_top_band = top.noise_floor_pct;
  }
  EXPECT_GT(previous_top_band, 3.0 * 100.0 * noise.tail(n - init).squaredNorm() /
                                   (linear.array() + 6.0 * linear.array().cube()).matrix().tail(n - init).squaredNorm());
  // A drive that does not repeat has no such floor.
  EXPECT_FALSE(periodic_noise_floor(gaussian(n, 0.5, 9), linear, init).has_value());
}

TEST(DiagnosisLevels, AGainThatGrowsWithTheDriveIsNonlinearAndOneThatDoesNotIsLinear) {
  // A cube's share of J ∝ level⁴: gains 0.01, 0.16 at levels 0.25 and 0.5 (slope 4); a mode's the same at each.
  const std::vector<LevelGain> cubic{{"quiet", 0.25, 1.00, 0.99}, {"loud", 0.5, 1.00, 0.84}};
  const LevelVerdict spring = judge_levels(Effect::cubic_stiffness, cubic);
  EXPECT_TRUE(spring.judged);
  EXPECT_NEAR(spring.slope, 4.0, 1e-9);
  EXPECT_TRUE(spring.grows);
  EXPECT_TRUE(spring.consistent);
  const LevelVerdict mode_like_a_spring = judge_levels(Effect::resonance, cubic);
  EXPECT_FALSE(mode_like_a_spring.consistent);
  const std::vector<LevelGain> flat{{"quiet", 0.25, 1.0, 0.9}, {"loud", 0.5, 0.5, 0.4}, {"middle", 0.35, 0.7, 0.6}};
  const LevelVerdict mode = judge_levels(Effect::resonance, flat);
  EXPECT_NEAR(mode.slope, 0.0, 1e-9);
  EXPECT_TRUE(mode.consistent);
  EXPECT_FALSE(judge_levels(Effect::cubic_stiffness, flat).consistent);
  // Only the loud record gains: it grows, at no rate the data give.
  const LevelVerdict only_loud = judge_levels(Effect::force_factor, {{"quiet", 0.25, 1.0, 1.01}, {"loud", 0.5, 1.0, 0.9}});
  EXPECT_TRUE(only_loud.grows);
  EXPECT_TRUE(std::isinf(only_loud.slope));
  // Levels too close, or a dc offset: no verdict.
  EXPECT_FALSE(judge_levels(Effect::cubic_stiffness, {{"a", 0.4, 1.0, 0.9}, {"b", 0.5, 1.0, 0.8}}).judged);
  EXPECT_FALSE(judge_levels(Effect::dc_offset, cubic).judged);
}

}  // namespace
}  // namespace panelbass::models::diagnosis_detail

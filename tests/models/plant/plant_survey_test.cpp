// The presets measured from simulated data, against what the thesis measured on its prototype
// (Moonen, ch. 3 and 6): fs = 3000 Hz, a 2-sample delay, an impulse response of about 200 samples, a
// second resonance near 1000 Hz with a notch near 900 Hz, linear-model J of a few percent (4.8 % in
// the thesis) over a sensor-noise floor below 1 %, and harmonic distortion that a linear plant lacks.

#include "models/plant/plant_survey.h"

#include <gtest/gtest.h>

#include "models/plant/plant_presets.h"

namespace panelbass::models {
namespace {

PlantSurvey survey(const std::string& preset, std::uint64_t seed) {
  PlantSurveySpec spec;
  spec.seed = seed;
  return survey_plant(plant_preset(preset), spec);
}

TEST(PlantSurvey, PanelExciterHasTheThesisPrototypesLinearProperties) {
  for (std::uint64_t seed : {1, 2, 3}) {
    const PlantSurvey s = survey("panel-exciter", seed);
    SCOPED_TRACE("seed " + std::to_string(seed));
    EXPECT_EQ(s.delay_samples, 2);
    // "about 200 samples" read off a plot: ±30 % covers what the estimate varies between records.
    EXPECT_GE(s.impulse_length_samples, 140);
    EXPECT_LE(s.impulse_length_samples, 260);
    EXPECT_NEAR(s.upper_resonance_hz, 1000.0, 50.0);
    EXPECT_NEAR(s.notch_hz, 900.0, 40.0);
    EXPECT_LT(s.notch_hz, s.upper_resonance_hz);
    EXPECT_GT(s.notch_depth_db, 6.0);
    EXPECT_GT(s.main_resonance_hz, 50.0);
    EXPECT_LT(s.main_resonance_hz, 400.0);
  }
}

TEST(PlantSurvey, PanelExciterLinearFitLeavesAFewPercentOverANoiseFloorBelowOnePercent) {
  double sum = 0.0;
  for (std::uint64_t seed : {1, 2, 3}) {
    const PlantSurvey s = survey("panel-exciter", seed);
    SCOPED_TRACE("seed " + std::to_string(seed));
    EXPECT_LT(s.j_noise_pct, 1.0);
    EXPECT_GT(s.j_noise_pct, 0.05);
    EXPECT_GT(s.j_linear_val_pct, 2.0);
    EXPECT_LT(s.j_linear_val_pct, 8.0);
    EXPECT_GT(s.j_linear_val_pct, 5.0 * s.j_noise_pct) << "the misfit must be nonlinearity, not noise";
    sum += s.j_linear_val_pct;
  }
  EXPECT_GT(sum / 3, 3.0);
  EXPECT_LT(sum / 3, 6.0);
}

TEST(PlantSurvey, LinearPresetLeavesOnlyTheNoise) {
  const PlantSurvey s = survey("linear", 1);
  // An FIR of 300 taps fitted on 10 000 samples: its validation J exceeds the noise floor by the
  // estimation variance, ≈ J_noise·(1 + 300/10 000), and by sampling spread of the 2 000 samples.
  EXPECT_LT(s.j_linear_val_pct, 1.3 * s.j_noise_pct);
  EXPECT_EQ(s.delay_samples, 2);
}

TEST(PlantSurvey, HarmonicDistortionPresentInPanelExciterAndAbsentInLinear) {
  const PlantSurvey nonlinear = survey("panel-exciter", 1);
  const PlantSurvey linear = survey("linear", 1);
  ASSERT_EQ(nonlinear.distortion.size(), 4u);
  ASSERT_EQ(linear.distortion.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) {
    SCOPED_TRACE(nonlinear.distortion[k].frequency_hz);
    EXPECT_GT(nonlinear.distortion[k].thd_pct, 1.0);
    EXPECT_LT(linear.distortion[k].thd_pct, 0.01);
    EXPECT_LT(linear.distortion[k].h2_db, -100.0);
    EXPECT_LT(linear.distortion[k].h3_db, -100.0);
  }
}

}  // namespace
}  // namespace panelbass::models

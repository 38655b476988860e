// The level sweep on cases whose answers are known: a chain that passes the program unchanged makes exactly
// the plant alone's output (the same drive, the same sensor noise seed), so the equal-level match finds the
// program's own amplitude and the cut is 0 dB; on the linear preset the only "distortion" is the sensor noise,
// whose THD the closed-form floor predicts.
#include <gtest/gtest.h>

#include <cmath>

#include "evaluation/level_sweep.h"
#include "models/plant/plant_presets.h"

namespace panelbass::evaluation {
namespace {

engine::ChainConfig pass_through_chain() {
  engine::ChainConfig c;
  c.fs = 3000.0;
  c.band_pass.bypass = true;  // no stage but the limiter, which leaves a drive below its knee unchanged
  return c;
}

LevelSweepOptions short_sweep() {
  LevelSweepOptions o;
  o.frequencies_hz = {80.0};
  o.program_amplitudes = {0.1, 0.3};
  o.settle_seconds = 0.3;
  o.analysis_seconds = 1.0;
  return o;
}

TEST(LevelSweep, PassThroughChainMatchesThePlantAloneAtItsOwnDrive) {
  const LevelSweep sweep = sweep_levels(pass_through_chain(), models::plant_preset("panel-exciter"), short_sweep());
  ASSERT_EQ(sweep.curves.size(), 1u);
  ASSERT_EQ(sweep.curves[0].points.size(), 2u);
  for (const LevelPoint& p : sweep.curves[0].points) {
    EXPECT_TRUE(p.reachable);
    EXPECT_NEAR(p.plant_drive, p.program_amplitude, 1e-12);  // the first trial already matches exactly
    EXPECT_NEAR(p.cut_db, 0.0, 1e-9);
    EXPECT_GT(p.plant.thd_pct, 1.0);  // panel-exciter distorts at 80 Hz
  }
  for (const ImdPoint& p : sweep.imd) EXPECT_NEAR(p.cut_db, 0.0, 1e-9);
}

TEST(LevelSweep, LinearPlantShowsTheSensorNoiseFloor) {
  const models::PlantConfig plant = models::plant_preset("linear");
  const LevelSweep sweep = sweep_levels(pass_through_chain(), plant, short_sweep());
  for (const LevelPoint& p : sweep.curves[0].points) {
    // the noise's DFT amplitude at each harmonic has mean square 4σ²/n: the measured THD scatters about that floor
    EXPECT_GT(p.chain.thd_pct, 0.3 * p.noise_floor_pct);
    EXPECT_LT(p.chain.thd_pct, 2.5 * p.noise_floor_pct);
  }
  EXPECT_GT(sweep.curves[0].points[0].noise_floor_pct, 2.0 * sweep.curves[0].points[1].noise_floor_pct);
}

TEST(LevelSweep, BadOptionsAreNamed) {
  LevelSweepOptions o = short_sweep();
  o.program_amplitudes = {1.5};
  EXPECT_THROW((void)sweep_levels(pass_through_chain(), models::plant_preset("linear"), o), std::invalid_argument);
  o = short_sweep();
  o.imd_high_hz = 60.0;
  EXPECT_THROW((void)sweep_levels(pass_through_chain(), models::plant_preset("linear"), o), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::evaluation

// The level sweep on cases whose answers are known: a chain that passes the program unchanged makes exactly
// the plant alone's output (the same drive, the same sensor noise seed), so the equal-level match finds the
// program's own amplitude and the cut is 0 dB; on the linear preset the only "distortion" is the sensor noise,
// whose THD the closed-form floor predicts.
// A chain with a gain asks for more than full scale at the louder level, which the sweep reports (needs_more_drive).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "evaluation/evaluation_json.h"
#include "evaluation/level_sweep.h"
#include "models/linear/linear_model.h"
#include "models/plant/plant_presets.h"
#include "tests/support/controllers.h"

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

TEST(LevelSweep, SaysWhereTheProgramNeedsMoreDriveThanTheChainCanGive) {
  // a feedforward u + 2·u(k−1) and nothing else, |H| ≈ 3 at 80 Hz: program 0.2 asks for about 0.6 (inside the
  // limiter's knee), 0.4 for about 1.2
  const double w = 2.0 * std::numbers::pi * 80.0 / 3000.0;
  const double gain = std::sqrt(5.0 + 4.0 * std::cos(w));  // |1 + 2·e^{−jω}|
  engine::ChainConfig chain = pass_through_chain();
  chain.feedforward = engine::SlotConfig{};
  chain.feedforward->model = testing_support::fir_gain_controller(2.0);
  LevelSweepOptions o = short_sweep();
  o.program_amplitudes = {0.2, 0.4};
  const LevelSweep sweep = sweep_levels(chain, models::plant_preset("panel-exciter"), o);
  const std::vector<LevelPoint>& points = sweep.curves.at(0).points;
  ASSERT_EQ(points.size(), 2u);
  // the peak asked is |H| × the sampled sine's: between |H|·a·cos(π·80/3000) and |H|·a
  for (const LevelPoint& p : points) {
    EXPECT_LE(p.peak_demand, gain * p.program_amplitude + 1e-12);
    EXPECT_GE(p.peak_demand, gain * p.program_amplitude * std::cos(std::numbers::pi * 80.0 / 3000.0));
  }
  EXPECT_FALSE(points[0].needs_more_drive);
  EXPECT_TRUE(points[0].reachable);
  EXPECT_TRUE(points[1].needs_more_drive);
  EXPECT_FALSE(points[1].reachable);
  EXPECT_LE(points[1].chain.drive_peak, 1.0);  // what the limiter let through
  const nlohmann::json j = level_sweep_to_json(sweep);
  EXPECT_EQ(j["curves"][0]["points"][1]["needs_more_drive"], true);
  EXPECT_EQ(j["curves"][0]["points"][0]["needs_more_drive"], false);
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

#include "usecases/equal_output_thd.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "evaluation/level_sweep.h"
#include "models/control/mirror_filter.h"
#include "models/plant/plant_config.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

// The transducer a test plays through: `plant` simulated on each drive (a new noise seed each time), recording
// the largest |drive| it was ever given.
struct SimulatedPort {
  models::PlantConfig plant;
  double largest_drive = 0.0;
  std::uint64_t seed = 7;
  PlayFunction play() {
    return [this](const Eigen::VectorXd& drive) {
      largest_drive = std::max(largest_drive, drive.cwiseAbs().maxCoeff());
      const models::PlantRecord r = models::simulate(plant, drive, seed++);
      return Playback{r.y, r.i, Eigen::VectorXd(), nullptr};
    };
  }
};

engine::ChainConfig band_pass_chain(double fs) {
  engine::ChainConfig c;
  c.fs = fs;
  return c;  // 20-1200 Hz, order 2, no models
}

// |H(f)| of the chain's band-pass by the bilinear transform's closed form: Butterworth high- and low-pass of
// order n with their -3 dB corners prewarped.
double band_pass_gain(const engine::BandPassDesign& d, double f, double fs) {
  const auto w = [fs](double hz) { return std::tan(std::numbers::pi * hz / fs); };
  const double n2 = 2.0 * d.order;
  const double hp = 1.0 / std::sqrt(1.0 + std::pow(w(d.low.value) / w(f), n2));
  const double lp = 1.0 / std::sqrt(1.0 + std::pow(w(f) / w(d.high.value), n2));
  return hp * lp;
}

EqualOutputSettings short_settings() {
  EqualOutputSettings s;
  s.frequencies = {40.0, 80.0};
  s.levels = {0.1, 0.3};
  return s;
}

TEST(EqualOutputThd, ABandPassAloneBuysNothingAndTheTransducerAloneIsDrivenAtItsGain) {
  SimulatedPort port{models::without_sensor_noise(models::plant_preset("panel-exciter"))};
  EqualOutputRequest q;
  q.chain = band_pass_chain(port.plant.fs);
  q.settings = short_settings();
  SilentProgress quiet;
  const EqualOutputReport r = verify_equal_output(q, port.play(), quiet);
  ASSERT_EQ(r.points.size(), 4u);
  for (const EqualOutputPoint& p : r.points) {
    ASSERT_TRUE(p.reachable) << p.frequency_hz << " Hz: " << p.unreachable_because;
    // the same sine reaches the transducer either way, scaled by the band-pass: the same output needs that drive
    const double expected = band_pass_gain(q.chain.band_pass.design, p.frequency_hz, q.chain.fs) * p.program_level;
    EXPECT_NEAR(20.0 * std::log10(p.plant_drive / expected), 0.0, 0.15) << p.frequency_hz << " Hz at " << p.program_level;
    ASSERT_TRUE(p.cut_db.has_value());
    EXPECT_NEAR(*p.cut_db, 0.0, 0.3) << p.frequency_hz << " Hz at " << p.program_level;  // THD ~ level²: 2 × 0.1 dB
    EXPECT_GT(p.plant.thd_pct, 0.5);  // panel-exciter distorts here, so the comparison means something
  }
  EXPECT_LE(r.plays, 1 + q.settings.max_plays);
  EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
}

TEST(EqualOutputThd, AMirrorFilterIsCreditedWithTheCutTheOfflineLevelSweepFinds) {
  const models::PlantConfig plant = models::without_sensor_noise(models::plant_preset("panel-exciter"));
  // The filter designed from a record of the plant (drive, current, displacement), as `design mirror` does.
  const Eigen::VectorXd drive = 0.5 * Eigen::VectorXd::NullaryExpr(12000, [](Eigen::Index k) {
    const double t = static_cast<double>(k) / 3000.0;
    return 0.5 * std::sin(2 * std::numbers::pi * 23.0 * t) + 0.3 * std::sin(2 * std::numbers::pi * 61.0 * t + 1.0) +
           0.2 * std::sin(2 * std::numbers::pi * 137.0 * t + 2.0);
  });
  const models::PlantRecord rec = models::simulate(plant, drive, 3);
  const models::MirrorModel mirror = models::fit_mirror_model(drive, rec.i, rec.x, plant.fs).model;
  engine::ChainConfig chain = band_pass_chain(plant.fs);
  chain.feedforward = engine::SlotConfig{};
  chain.feedforward->model = models::mirror_model_to_json(mirror);
  EqualOutputRequest q;
  q.chain = chain;
  q.settings.frequencies = {80.0};
  q.settings.levels = {0.2};
  SimulatedPort port{plant};
  SilentProgress quiet;
  const EqualOutputReport r = verify_equal_output(q, port.play(), quiet);
  ASSERT_EQ(r.points.size(), 1u);
  ASSERT_TRUE(r.points[0].reachable) << r.points[0].unreachable_because;
  ASSERT_TRUE(r.points[0].cut_db.has_value());
  // The same comparison by the offline level sweep (its own windows, its own level search).
  evaluation::LevelSweepOptions o;
  o.frequencies_hz = {80.0};
  o.program_amplitudes = {0.2};
  const evaluation::LevelSweep offline = evaluation::sweep_levels(chain, plant, o);
  const double expected = offline.curves[0].points[0].cut_db;
  EXPECT_GT(expected, 6.0);  // the filter does cut here
  EXPECT_NEAR(*r.points[0].cut_db, expected, 1.0);
}

TEST(EqualOutputThd, ALevelTheChainCannotReachIsNotPlayedAndSaysWhy) {
  SimulatedPort port{models::without_sensor_noise(models::plant_preset("panel-exciter"))};
  EqualOutputRequest q;
  q.chain = band_pass_chain(port.plant.fs);
  q.safe_level = 0.25;
  q.settings.frequencies = {80.0};
  q.settings.levels = {0.1, 0.4};
  SilentProgress quiet;
  const EqualOutputReport r = verify_equal_output(q, port.play(), quiet);
  ASSERT_EQ(r.points.size(), 2u);
  EXPECT_TRUE(r.points[0].reachable);
  EXPECT_FALSE(r.points[1].reachable);
  EXPECT_NE(r.points[1].unreachable_because.find("beyond the safe level 0.25"), std::string::npos) << r.points[1].unreachable_because;
  EXPECT_LE(port.largest_drive, 0.25);
  EXPECT_FALSE(r.worst_cut_db(80.0).has_value() && std::isnan(*r.worst_cut_db(80.0)));
}

TEST(EqualOutputThd, SettingsOutOfRangeAreNamed) {
  const auto field_of = [](EqualOutputSettings s) {
    try {
      check(s, 3000.0);
    } catch (const RequestError& e) {
      return e.field();
    }
    return std::string("accepted");
  };
  EqualOutputSettings s;
  s.frequencies = {800.0};  // its third harmonic beyond fs/2
  EXPECT_EQ(field_of(s), "frequencies");
  s = {};
  s.levels = {0.0};
  EXPECT_EQ(field_of(s), "levels");
  s = {};
  s.analysis_seconds = 0.05;
  EXPECT_EQ(field_of(s), "analysis_seconds");
  s = {};
  s.max_plays = 0;
  EXPECT_EQ(field_of(s), "max_plays");
  EXPECT_EQ(field_of({}), "accepted");
}

}  // namespace
}  // namespace panelbass::usecases

// The mirror filter as a chain stage: built from its model file by the stage factory, it runs exactly the
// model's filter (models/control/mirror_filter.h) sample by sample, and refuses a chain at another rate; adapting
// from the coil current, it follows a ±20 % variant of the transducer its model was fitted on and cuts more
// distortion there than the fixed filter.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>

#include <algorithm>

#include "dsp/excitation.h"
#include "dsp/harmonics.h"
#include "engine/mirror_filter_stage.h"
#include "engine/stage_factory.h"
#include "models/control/mirror_current_fit.h"
#include "models/control/mirror_filter.h"
#include "models/plant/plant_presets.h"
#include "models/plant/plant_variants.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::engine {
namespace {

models::MirrorModel small_model() {
  models::MirrorModel m;
  m.fs = 3000.0;
  m.electrical = {1.5e-5, 0.0, 0.0, -3e-7, 0.2, 7.5e-5, 0.0, -3.4e-5, 0.0, 0.0};
  m.mechanical = {1.5e5, 0.0, -6.75e4, 0.0, 0.0, -40.0, -8.88e5, -2.66e4, -5.33e4, -5000.0};
  m.friction_velocity = 50.0;
  return m;
}

TEST(MirrorFilterStage, FactoryStageRunsTheModelsFilter) {
  const models::MirrorModel model = small_model();
  std::unique_ptr<Stage> stage = make_stage(models::mirror_model_to_json(model), models::ModelRole::feedforward);
  stage->prepare({3000.0, 64});
  Eigen::VectorXd program(600);
  for (Eigen::Index k = 0; k < program.size(); ++k) program[k] = 0.4 * std::sin(2.0 * std::numbers::pi * 80.0 * k / 3000.0);
  const Eigen::VectorXd expected = models::mirror_filter(model, program);
  for (Eigen::Index k = 0; k < program.size(); ++k) EXPECT_DOUBLE_EQ(stage->process(program[k]), expected[k]);
}

TEST(MirrorFilterStage, AdaptiveStageFindsTheStiffnessOfThePlantItDrives) {
  // the stage closed over a plant its model describes exactly but for a stiffness 1.44 times the model's (the
  // resonance 1.2 times higher), the sensor [S1] a scaled difference of the velocity, noise-free: the stage's
  // observer finds the plant's stiffness from the sensor alone and keeps the others at 1
  models::MirrorModel model = small_model();
  model.observer = {true, {2e-3, -2e-3, 0.0, 0.0}, 1e-3, 1.0, 1e-4, 0.3, 1e-4, 0.1, 1e-4, 0.3};
  models::MirrorModel plant = model;
  for (std::size_t j : {6u, 7u, 8u}) plant.mechanical[j] *= 1.44;
  MirrorFilterStage stage(model);
  EXPECT_TRUE(stage.observes());
  EXPECT_FALSE(MirrorFilterStage(small_model()).observes());
  stage.prepare({3000.0, 64});
  models::MirrorState s;
  std::array<double, 4> v{};  // the plant's velocity rows k..k−3
  for (int k = 0; k < 6000; ++k) {
    const double program = 0.2 * std::sin(2.0 * std::numbers::pi * 60.0 * k / 3000.0) +
                           0.1 * std::sin(2.0 * std::numbers::pi * 170.0 * k / 3000.0);
    const double drive = stage.process(program);
    // delay 0: the drive of sample k takes the plant's row k to row k + 1; the sensor reads rows k..k−3
    stage.observe(2e-3 * (v[0] - v[1]));
    models::step_mirror_model(plant, s, drive);
    v = {s.v, v[0], v[1], v[2]};
  }
  ASSERT_NE(stage.observer(), nullptr);
  EXPECT_NEAR(stage.observer()->scales().stiffness, 1.44, 0.015);
  EXPECT_NEAR(stage.observer()->scales().force, 1.0, 0.01);
  EXPECT_NEAR(stage.observer()->scales().nonlinear, 1.0, 0.03);
}

TEST(MirrorFilterStage, AdaptiveStageWithoutASensorKeepsItsModel) {
  // a chain run without a sensor observes zeros: the adaptive stage then gives what the open-loop filter gives
  models::MirrorModel model = small_model();
  model.observer = {true, {2e-3, -2e-3, 0.0, 0.0}, 1e-3, 1.0, 1e-4, 0.3, 1e-4, 0.1, 1e-4, 0.3};
  MirrorFilterStage stage(model);
  stage.prepare({3000.0, 64});
  Eigen::VectorXd program(3000);
  for (Eigen::Index k = 0; k < program.size(); ++k) program[k] = 0.3 * std::sin(2.0 * std::numbers::pi * 80.0 * k / 3000.0);
  const Eigen::VectorXd expected = models::mirror_filter(small_model(), program);
  for (Eigen::Index k = 0; k < program.size(); ++k) {
    ASSERT_DOUBLE_EQ(stage.process(program[k]), expected[k]) << "sample " << k;
    stage.observe(0.0);
  }
}

/// The THD (%) and fundamental of `plant`'s clean sensor output over the last second of a 2 s sine of `amplitude` at
/// 80 Hz through `stage` (null: the sine drives the plant alone), after `warmup` (a broadband program) through it;
/// the plant's coil current is fed back to the stage, as a card that records it would.
std::pair<double, double> thd_through(const models::PlantConfig& plant, MirrorFilterStage* stage,
                                      const Eigen::VectorXd& warmup, double amplitude) {
  models::VirtualTransducer t(plant, 1);
  const auto drive_of = [&](double program) {
    if (stage == nullptr) return program;
    return std::clamp(stage->process(program), -1.0, 1.0);
  };
  for (Eigen::Index k = 0; k < warmup.size(); ++k) {
    const models::PlantSample s = t.step(drive_of(warmup[k]));
    if (stage != nullptr) stage->observe(s.i);
  }
  const int n = 6000, fs = 3000;
  Eigen::VectorXd y(fs);
  for (int k = 0; k < n; ++k) {
    const models::PlantSample s = t.step(drive_of(amplitude * std::sin(2.0 * std::numbers::pi * 80.0 * k / fs)));
    if (stage != nullptr) stage->observe(s.i);
    if (k >= n - fs) y[k - (n - fs)] = s.y_clean;
  }
  const dsp::HarmonicLevels h = dsp::harmonic_levels(y, fs, 80.0);
  return {h.thd_percent(), h.amplitude[0]};
}

/// 20·log10 of the plant alone's THD at the stage's output fundamental (its sine amplitude scaled until they match)
/// over the stage's THD.
double cut_db(const models::PlantConfig& plant, MirrorFilterStage& stage, const Eigen::VectorXd& warmup) {
  const auto [thd, fundamental] = thd_through(plant, &stage, warmup, 0.2);
  double amplitude = 0.2, alone = 0.0;
  for (int it = 0; it < 5; ++it) {
    const auto [t, f] = thd_through(plant, nullptr, Eigen::VectorXd(), amplitude);
    alone = t;
    amplitude *= fundamental / f;
  }
  return 20.0 * std::log10(alone / thd);
}

TEST(MirrorFilterStage, AdaptingFromTheCurrentFollowsAVariantOfItsTransducer) {
  // the filter fitted from panel-exciter's drive and current alone, then run on its ±20 % variant (Bl +20 %,
  // K −20 %, Le +20 %, friction +20 %: `plant vary --by 0.2 --seed 3`) with the variant's coil current fed back: the
  // adapter finds Bl and K moved by the variant's factors (Bl/m and K/m, m unchanged), and the adaptive filter cuts
  // the 80 Hz THD at equal output by more than the fixed one does
  models::PlantConfig plant = models::plant_preset("panel-exciter");
  plant.sensor.noise_rms_V = 0.0;
  dsp::MultisineSpec spec;
  spec.period = 12000;
  spec.f_min = 10.0;
  spec.f_max = 300.0;
  spec.amplitude = 0.5;
  spec.seed = 1;
  const Eigen::VectorXd drive = dsp::multisine(spec).signal;
  const models::PlantRecord rec = models::simulate(plant, drive, 1);
  const models::MirrorCurrentFit fit = models::fit_mirror_model_from_current(drive, rec.i, plant.fs);
  models::MirrorModel adaptive = fit.model;
  adaptive.observer.enabled = true;
  adaptive.observer.measurement = models::MirrorMeasurement::current;
  adaptive.observer.current_lag = fit.current_lag;
  adaptive.observer.current_noise = 0.01 * std::sqrt(rec.i.squaredNorm() / static_cast<double>(rec.i.size()));

  const models::VariantFactors factors = models::variant_factors(0.2, 3);
  const models::PlantConfig variant = models::varied_plant(plant, factors);
  spec.amplitude = 0.4;
  spec.seed = 7;
  const Eigen::VectorXd warmup = dsp::multisine(spec).signal;  // 4 s of broadband program
  MirrorFilterStage fixed(fit.model), adapting(adaptive);
  fixed.prepare({3000.0, 64});
  adapting.prepare({3000.0, 64});
  const double fixed_cut = cut_db(variant, fixed, warmup);
  const double adaptive_cut = cut_db(variant, adapting, warmup);
  ASSERT_NE(adapting.current_adapter(), nullptr);
  RecordProperty("fixed_cut_db", std::to_string(fixed_cut));
  RecordProperty("adaptive_cut_db", std::to_string(adaptive_cut));
  const models::MirrorScales scales = adapting.current_adapter()->scales();
  RecordProperty("scales", std::to_string(scales.force_factor) + " " + std::to_string(scales.stiffness));
  EXPECT_NEAR(scales.force_factor, factors.force_factor, 0.06) << "Bl";
  EXPECT_NEAR(scales.stiffness, factors.stiffness, 0.06) << "K";
  EXPECT_GT(adaptive_cut, fixed_cut + 6.0) << "fixed " << fixed_cut << " dB, adaptive " << adaptive_cut << " dB";
}

TEST(MirrorFilterStage, RefusesAnotherRate) {
  MirrorFilterStage stage(small_model());
  EXPECT_THROW(stage.prepare({48000.0, 64}), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::engine

// Stepped-sine distortion against independent expectations: the `linear` preset (every nonlinear term
// off, sensor noise off) has no harmonics beyond rounding; the `panel-exciter` preset at a large drive
// has more than 1 % THD; the plant measured through a plain wrapper of models::simulate gives the same
// rows bit for bit; a linear model's fundamental is the drive amplitude times |H(e^{jω})| from
// TransferFunction::response, with no harmonics, and harmonics at or above Nyquist are NaN.
#include "models/distortion_comparison.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "models/plant_presets.h"
#include "models/virtual_transducer.h"
#include "tests/support/expect_error.h"
#include "tests/support/vectors.h"

namespace panelbass::models {
namespace {

using testing_support::expect_invalid;
using testing_support::vec;

DistortionSpec small_spec() {
  DistortionSpec spec;
  spec.frequencies = {60.0, 150.0, 400.0, 700.0};
  spec.amplitudes = {0.6};
  spec.settle = 600;
  spec.measure = 1500;
  return spec;
}

void expect_identical(const std::vector<DistortionRow>& a, const std::vector<DistortionRow>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].frequency, b[i].frequency);
    EXPECT_EQ(a[i].amplitude, b[i].amplitude);
    EXPECT_EQ(a[i].fundamental, b[i].fundamental);
    if (std::isnan(a[i].thd_percent)) {
      EXPECT_TRUE(std::isnan(b[i].thd_percent));
    } else {
      EXPECT_EQ(a[i].thd_percent, b[i].thd_percent);
    }
    ASSERT_EQ(a[i].harmonic_db.size(), b[i].harmonic_db.size());
    for (std::size_t h = 0; h < a[i].harmonic_db.size(); ++h) {
      if (std::isnan(a[i].harmonic_db[h])) {
        EXPECT_TRUE(std::isnan(b[i].harmonic_db[h]));
      } else {
        EXPECT_EQ(a[i].harmonic_db[h], b[i].harmonic_db[h]);
      }
    }
  }
}

TEST(DistortionComparisonTest, LinearPresetHasNoHarmonics) {
  DistortionSpec spec = small_spec();
  spec.sensor_noise = SensorNoise::off;
  const std::vector<DistortionRow> rows = plant_distortion(plant_preset("linear"), spec);
  ASSERT_EQ(rows.size(), 4u);
  for (const DistortionRow& row : rows) {
    EXPECT_GT(row.fundamental, 0.0);
    EXPECT_LT(row.thd_percent, 0.01) << row.frequency << " Hz";
    EXPECT_EQ(row.harmonic_db.size(), 4u);
  }
}

TEST(DistortionComparisonTest, PanelExciterDistortsAtLargeDrive) {
  DistortionSpec spec = small_spec();
  spec.sensor_noise = SensorNoise::off;
  const std::vector<DistortionRow> rows = plant_distortion(plant_preset("panel-exciter"), spec);
  double worst = 0.0;
  for (const DistortionRow& row : rows) worst = std::max(worst, row.thd_percent);
  EXPECT_GT(worst, 1.0);
}

TEST(DistortionComparisonTest, PlantThroughAWrapperGivesIdenticalRows) {
  const PlantConfig plant = plant_preset("panel-exciter");
  DistortionSpec spec = small_spec();
  spec.amplitudes = {0.2, 0.6};
  spec.frequencies = {150.0, 400.0};
  spec.noise_seed = 5;  // sensor noise kept: the same seed gives the same noise
  const auto wrapped = [&](const Eigen::VectorXd& u) { return simulate(plant, u, 5).y; };
  const std::vector<DistortionRow> direct = plant_distortion(plant, spec);
  ASSERT_EQ(direct.size(), 4u);
  EXPECT_EQ(direct[0].amplitude, 0.2);
  EXPECT_EQ(direct[2].amplitude, 0.6);
  expect_identical(direct, measure_distortion(wrapped, plant.fs, spec));
}

TEST(DistortionComparisonTest, LinearModelGivesItsFrequencyResponseAndNoHarmonics) {
  LinearModel linear;
  linear.tf.a = vec({-1.0, 0.64});  // poles at radius 0.8: settled to 1e-50 after 600 samples
  linear.tf.b = vec({0.5, 0.3});
  linear.tf.nk = 1;
  linear.fs = 3000.0;
  linear.scaling.u_scale = 0.5;  // raw → raw gain: H·y_scale/u_scale
  linear.scaling.y_scale = 4.0;
  const AnyModel model{linear};
  DistortionSpec spec = small_spec();
  spec.frequencies = {100.0, 700.0, 900.0};
  spec.amplitudes = {0.3, 0.9};
  const std::vector<DistortionRow> rows = model_distortion(model, spec);
  ASSERT_EQ(rows.size(), 6u);
  for (const DistortionRow& row : rows) {
    const double expected = row.amplitude * std::abs(linear.tf.response(row.frequency, linear.fs)) * 8.0;
    EXPECT_NEAR(row.fundamental, expected, 1e-9 * expected) << row.frequency;
    if (row.frequency < 750.0) {
      EXPECT_LT(row.thd_percent, 1e-9);
    }
  }
  EXPECT_EQ(rows[3].amplitude, 0.9);
  EXPECT_EQ(rows[3].frequency, 100.0);
  // 700 Hz at fs = 3000: H2 = 1400 Hz is measured, H3 = 2100 Hz lies above Nyquist.
  EXPECT_FALSE(std::isnan(rows[1].harmonic_db[0]));
  EXPECT_TRUE(std::isnan(rows[1].harmonic_db[1]));
  EXPECT_TRUE(std::isnan(rows[1].harmonic_db[3]));
  // 900 Hz: no harmonic below Nyquist, so no THD either.
  EXPECT_TRUE(std::isnan(rows[2].harmonic_db[0]));
  EXPECT_TRUE(std::isnan(rows[2].thd_percent));

  const DistortionComparison both = compare_distortion(plant_preset("linear"), model, spec);
  EXPECT_EQ(both.model.size(), both.plant.size());
  expect_identical(both.model, rows);
  PlantConfig other_rate = plant_preset("linear");
  other_rate.fs = 6000.0;
  expect_invalid([&] { compare_distortion(other_rate, model, spec); }, "6000");
}

TEST(DistortionComparisonTest, RejectsBadSpecsAndSystems) {
  const auto identity = [](const Eigen::VectorXd& u) { return u; };
  DistortionSpec spec = small_spec();
  spec.frequencies.clear();
  expect_invalid([&] { measure_distortion(identity, 3000.0, spec); }, "no frequencies");
  spec = small_spec();
  spec.amplitudes.clear();
  expect_invalid([&] { measure_distortion(identity, 3000.0, spec); }, "no amplitudes");
  spec = small_spec();
  spec.max_order = 1;
  expect_invalid([&] { measure_distortion(identity, 3000.0, spec); }, "max_order");
  spec = small_spec();
  expect_invalid([&] { measure_distortion([](const Eigen::VectorXd& u) { return u.head(10).eval(); }, 3000.0, spec); },
                 "returned 10 samples");
  expect_invalid(
      [&] {
        measure_distortion([](const Eigen::VectorXd& u) { return Eigen::VectorXd(u.array() / 0.0); }, 3000.0, spec);
      },
      "not finite");
}

}  // namespace
}  // namespace panelbass::models

// Stepped-sine distortion against independent expectations: the `linear` preset (every nonlinear term
// off, sensor noise off) has no harmonics beyond rounding; the `panel-exciter` preset at a large drive
// has more than 1 % THD; the plant measured through a plain wrapper of models::simulate gives the same
// rows bit for bit; a linear model's fundamental is the drive amplitude times |H(e^{jω})| from
// TransferFunction::response, with no harmonics, and harmonics at or above Nyquist are NaN.
#include "models/analysis/distortion_comparison.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>

#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
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

// Static polynomials y = x + b·x² + c·x³ on a sine of amplitude A: the fundamental is A + 3·c·A³/4, H2 is
// b·A²/2 and H3 c·A³/4, each in phase with the cosine fundamental (their sign is the coefficient's). So a
// "recording" with (b, c) set against a model with (−b, −c) has harmonics of nearly the same levels and
// opposite phase: the levels alone promise a large cut, the complex difference says the canceller doubles them.
TEST(DistortionComparisonTest, CancellableDistortionIsTheComplexDifferenceOfTheHarmonics) {
  const double amplitude = 0.6, b = 0.05, c = 0.08;
  const auto polynomial = [](double bb, double cc, Eigen::Index delay) {
    return [=](const Eigen::VectorXd& u) {
      Eigen::VectorXd y = Eigen::VectorXd::Zero(u.size());
      for (Eigen::Index k = delay; k < u.size(); ++k) {
        const double x = u[k - delay];
        y[k] = x + bb * x * x + cc * x * x * x;
      }
      return y;
    };
  };
  DistortionSpec spec = small_spec();
  spec.frequencies = {60.0, 150.0};
  spec.amplitudes = {amplitude};
  const std::vector<DistortionRow> recorded = measure_distortion(polynomial(b, c, 0), 3000.0, spec);
  const std::vector<DistortionRow> opposite = measure_distortion(polynomial(-b, -c, 0), 3000.0, spec);
  const std::vector<DistortionRow> delayed = measure_distortion(polynomial(b, c, 5), 3000.0, spec);
  const std::vector<DistortionRow> linear = measure_distortion(polynomial(0.0, 0.0, 0), 3000.0, spec);
  const double a = amplitude;
  const double r2 = b * a * a / 2 / (a + 0.75 * c * a * a * a), r3 = c * a * a * a / 4 / (a + 0.75 * c * a * a * a);
  const double m2 = -b * a * a / 2 / (a - 0.75 * c * a * a * a), m3 = -c * a * a * a / 4 / (a - 0.75 * c * a * a * a);
  const double complex_db = 10 * std::log10((r2 * r2 + r3 * r3) / ((r2 - m2) * (r2 - m2) + (r3 - m3) * (r3 - m3)));
  const double levels_db = 10 * std::log10((r2 * r2 + r3 * r3) /
                                           ((r2 + m2) * (r2 + m2) + (r3 + m3) * (r3 + m3)));  // |m| = −m here
  ASSERT_EQ(recorded.size(), 2u);
  for (std::size_t k = 0; k < recorded.size(); ++k) {
    EXPECT_NEAR(std::real(recorded[k].harmonic_relative[0]), r2, 1e-9);
    EXPECT_NEAR(std::real(recorded[k].harmonic_relative[1]), r3, 1e-9);
    EXPECT_NEAR(cancellable_db(recorded[k], opposite[k]), complex_db, 1e-6);  // ≈ −6 dB: doubled
    EXPECT_NEAR(cancellable_magnitude_db(recorded[k], opposite[k]), levels_db, 1e-6);
    EXPECT_LT(complex_db, -5.0);
    EXPECT_GT(levels_db, 20.0);
    // The same polynomial behind a delay of 5 samples: the same harmonics against their fundamental.
    EXPECT_GT(cancellable_db(recorded[k], delayed[k]), 150.0);
    // A model without harmonics removes nothing.
    EXPECT_NEAR(cancellable_db(recorded[k], linear[k]), 0.0, 1e-9);
    EXPECT_NEAR(cancellable_magnitude_db(recorded[k], linear[k]), 0.0, 1e-9);
  }
  expect_invalid([&] { cancellable_db(recorded[0], recorded[1]); }, "150");
  DistortionSpec high = spec;
  high.frequencies = {900.0};  // H2 = 1800 Hz lies above Nyquist at 3000 Hz
  const std::vector<DistortionRow> none = measure_distortion(polynomial(b, c, 0), 3000.0, high);
  expect_invalid([&] { cancellable_db(none[0], none[0]); }, "no harmonic");
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

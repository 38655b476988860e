// `panelbass harmonics`: stepped-sine distortion of a plant, and of a model beside it (fig. 6.7).

#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

using namespace testing_support;
using CliHarmonics = CliTest;

TEST_F(CliHarmonics, LinearPlantHasNoHarmonicsAndPanelExciterHas) {
  const json linear = expect_result(run("harmonics --plant linear --freqs 50,200 --amplitudes 0.5"));
  ASSERT_EQ(linear["plant_rows"].size(), 2u);
  for (const auto& row : linear["plant_rows"]) EXPECT_LT(row["thd_pct"].get<double>(), 0.01);
  const json panel = expect_result(run("harmonics --plant panel-exciter --freqs 50,200 --amplitudes 0.5,0.9"));
  ASSERT_EQ(panel["plant_rows"].size(), 4u);
  for (const auto& row : panel["plant_rows"]) EXPECT_GT(row["thd_pct"].get<double>(), 1.0);
  // More drive, more distortion (amplitude-major order: rows 2 and 3 are at 0.9).
  EXPECT_GT(panel["plant_rows"][2]["thd_pct"].get<double>(), panel["plant_rows"][0]["thd_pct"].get<double>());
}

TEST_F(CliHarmonics, ModelRowsBesideThePlantRows) {
  const fs::path data = dir_ / "run.csv";
  expect_result(run("simulate --plant linear --samples 4000 --seed 3 --out " + quoted(data)));
  const fs::path model = dir_ / "lin.json";
  expect_result(run("identify linear --data " + quoted(data) + " --fs 3000 --method oe --order 8 --out " + quoted(model)));
  const json r = expect_result(run("harmonics --plant linear --model " + quoted(model) + " --freqs 100,300 --amplitudes 0.5"));
  ASSERT_EQ(r["model_rows"].size(), 2u);
  EXPECT_EQ(r["kind"], "linear");
  for (std::size_t k = 0; k < 2; ++k) {
    // A linear model of a linear plant: the same fundamental within the fit's accuracy, no harmonics.
    const double plant = r["plant_rows"][k]["fundamental"], fitted = r["model_rows"][k]["fundamental"];
    EXPECT_NEAR(fitted, plant, 0.03 * plant);
    // Only the tail of the settling transient leaks into the measured window.
    EXPECT_LT(r["model_rows"][k]["thd_pct"].get<double>(), 1e-3);
  }
  // Set against the panel exciter, which distorts, a model without harmonics can cancel none of it: 0 dB by the
  // complex difference and by the levels alone (within what the settling tail leaks, above); each harmonic's
  // phase is reported, in degrees.
  const json panel =
      expect_result(run("harmonics --plant panel-exciter --model " + quoted(model) + " --freqs 60,200 --amplitudes 0.7"));
  ASSERT_EQ(panel["cancellable"].size(), 2u);
  for (const auto& row : panel["cancellable"]) {
    EXPECT_NEAR(row["cancellable_db"].get<double>(), 0.0, 1e-3);
    EXPECT_NEAR(row["cancellable_magnitude_db"].get<double>(), 0.0, 1e-3);
  }
  EXPECT_NEAR(panel["smallest_cancellable_db"].get<double>(), 0.0, 1e-3);
  for (const auto& row : panel["plant_rows"]) {
    const double phase = row["phases"]["H3_deg"];
    EXPECT_LE(std::abs(phase), 180.0);
  }
}

TEST_F(CliHarmonics, RecordingMadeWithTheSteppedSineGivesThePlantsHarmonics) {
  const fs::path rec = dir_ / "rec.csv";
  expect_result(run("simulate --plant panel-exciter --signal stepped --freqs 60,200 --amplitude 0.7 --out " + quoted(rec)));
  const json from_file = expect_result(run("harmonics --data " + quoted(rec) + " --fs 3000 --freqs 60,200 --amplitudes 0.7"));
  const json from_plant = expect_result(run("harmonics --plant panel-exciter --noise --freqs 60,200 --amplitudes 0.7"));
  ASSERT_EQ(from_file["recording_rows"].size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    // The same plant, the same signal, the same noise seed: the same numbers.
    EXPECT_NEAR(from_file["recording_rows"][k]["thd_pct"].get<double>(), from_plant["plant_rows"][k]["thd_pct"].get<double>(),
                0.05 * from_plant["plant_rows"][k]["thd_pct"].get<double>());
  }
  // A recording of another signal is refused, naming the file.
  const RunResult wrong = run("harmonics --data " + quoted(rec) + " --fs 3000 --freqs 60,300 --amplitudes 0.7");
  expect_failure(wrong);
  EXPECT_TRUE(contains(wrong.err, "rec.csv")) << wrong.err;
}

TEST_F(CliHarmonics, BadModelFails) {
  const RunResult r = run("harmonics --model " + quoted(dir_ / "absent.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "absent.json")) << r.err;
}

}  // namespace
}  // namespace panelbass

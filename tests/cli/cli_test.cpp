// The `panelbass` command run as a user runs it: the real binary, its exit status (0 ok, 1 failed,
// 2 bad usage), its one JSON object on stdout, its files, and one error line on stderr when it fails.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "dsp/csv_table.h"
#include "dsp/record.h"
#include "dsp/wav_file.h"
#include "models/plant/plant_config.h"
#include "models/plant/plant_presets.h"
#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

double rms(const Eigen::VectorXd& x) { return std::sqrt(x.squaredNorm() / static_cast<double>(x.size())); }

using namespace testing_support;

using CliHelp = CliTest;
using CliUsage = CliTest;
using CliSimulate = CliTest;
using CliPlant = CliTest;


dsp::Record read_uyix_csv(const fs::path& path) { return dsp::read_csv(path, {"u", "y", "i", "x"}); }

// ---------------------------------------------------------------------------------------------
// Help

TEST_F(CliHelp, TopLevelHelpExitsZeroAndNamesTheVerbs) {
  const RunResult r = run("--help");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "simulate")) << r.out;
  EXPECT_TRUE(contains(r.out, "plant")) << r.out;
}

TEST_F(CliHelp, SimulateHelpHasAnExample) {
  const RunResult r = run("simulate --help");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "Example")) << r.out;
  EXPECT_TRUE(contains(r.out, "--samples")) << r.out;
}

TEST_F(CliHelp, PlantShowHelpHasAnExample) {
  const RunResult r = run("plant show --help");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "Example")) << r.out;
}

TEST_F(CliHelp, PlantSurveyHelpHasAnExample) {
  const RunResult r = run("plant survey --help");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "Example")) << r.out;
}

// ---------------------------------------------------------------------------------------------
// Bad usage: exit 2

TEST_F(CliUsage, NoVerb) { expect_usage_error(run("")); }

TEST_F(CliUsage, UnknownVerb) { expect_usage_error(run("frobnicate")); }

TEST_F(CliUsage, MissingSamples) {
  const RunResult r = run("simulate --out " + quoted(dir_ / "x.csv"));
  expect_usage_error(r);
  EXPECT_TRUE(contains(r.err, "--samples")) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "x.csv"));
}

TEST_F(CliUsage, AmplitudeAboveOne) {
  const RunResult r = run("simulate --samples 100 --amplitude 1.5 --out " + quoted(dir_ / "x.csv"));
  expect_usage_error(r);
  EXPECT_TRUE(contains(r.err, "--amplitude")) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "x.csv"));
}

TEST_F(CliUsage, UnknownSignal) {
  const RunResult r = run("simulate --samples 100 --signal chirp --out " + quoted(dir_ / "x.csv"));
  expect_usage_error(r);
  EXPECT_TRUE(contains(r.err, "--signal")) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "x.csv"));
}

// ---------------------------------------------------------------------------------------------
// simulate

TEST_F(CliSimulate, NoiseWritesTheRecordAndReportsItsRms) {
  constexpr int kSamples = 3000;
  const fs::path csv = dir_ / "run.csv";
  const json result = expect_result(run("simulate --samples 3000 --seed 7 --out " + quoted(csv)));

  EXPECT_EQ(result.value("samples", -1), kSamples);
  EXPECT_EQ(result.value("fs", 0.0), 3000.0);
  EXPECT_EQ(result.value("plant", ""), "panel-exciter");
  EXPECT_EQ(result.value("signal", ""), "noise");
  EXPECT_EQ(result.value("seed", -1), 7);
  EXPECT_EQ(result.value("noise_seed", -1), 8);  // documented default: seed + 1
  EXPECT_EQ(result.value("out", ""), csv.string());

  const std::string text = text_of(csv);
  EXPECT_EQ(text.substr(0, text.find('\n')), "u,y,i,x");
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), kSamples + 1);  // header + one row per sample

  const dsp::Record record = read_uyix_csv(csv);
  ASSERT_EQ(record.samples(), static_cast<std::size_t>(kSamples));
  EXPECT_LE(record.column("u").cwiseAbs().maxCoeff(), 1.0);
  ASSERT_TRUE(result.contains("rms") && result["rms"].is_object()) << result.dump();
  for (const char* name : {"u", "y", "i", "x"}) {
    SCOPED_TRACE(name);
    const double expected = rms(record.column(name));
    EXPECT_GT(expected, 0.0);
    ASSERT_TRUE(result["rms"].contains(name));
    EXPECT_NEAR(result["rms"][name].get<double>(), expected, 1e-9 * expected);
  }
}

TEST_F(CliSimulate, SameSeedSameFileOtherSeedOtherDrive) {
  const fs::path a = dir_ / "a.csv", b = dir_ / "b.csv", c = dir_ / "c.csv";
  expect_result(run("simulate --samples 2000 --seed 3 --out " + quoted(a)));
  expect_result(run("simulate --samples 2000 --seed 3 --out " + quoted(b)));
  expect_result(run("simulate --samples 2000 --seed 4 --out " + quoted(c)));
  const std::string text_a = text_of(a);
  EXPECT_FALSE(text_a.empty());
  EXPECT_TRUE(text_a == text_of(b)) << "the same seed gave different files";
  const Eigen::VectorXd u_a = read_uyix_csv(a).column("u");
  const Eigen::VectorXd u_c = read_uyix_csv(c).column("u");
  ASSERT_EQ(u_a.size(), u_c.size());
  // Independent uniform noises in [-1, 1]: E|u_a - u_c|² = 2/3 per sample.
  EXPECT_GT((u_a - u_c).squaredNorm() / static_cast<double>(u_a.size()), 0.3);
}

TEST_F(CliSimulate, SineIsTheClosedFormSine) {
  const fs::path csv = dir_ / "sine.csv";
  const json result = expect_result(run("simulate --signal sine --freq 100 --samples 3000 --out " + quoted(csv)));
  EXPECT_EQ(result.value("signal", ""), "sine");
  const Eigen::VectorXd u = read_uyix_csv(csv).column("u");
  ASSERT_EQ(u.size(), 3000);
  double worst = 0.0;
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    const double expected = std::sin(2.0 * std::numbers::pi * 100.0 * static_cast<double>(k) / 3000.0);
    worst = std::max(worst, std::abs(u[k] - expected));
  }
  EXPECT_LE(worst, 1e-12);
}

TEST_F(CliSimulate, MultisineRepeatsExactlyEveryPeriod) {
  const fs::path csv = dir_ / "multisine.csv";
  expect_result(run("simulate --signal multisine --period 1000 --samples 3000 --out " + quoted(csv)));
  const Eigen::VectorXd u = read_uyix_csv(csv).column("u");
  ASSERT_EQ(u.size(), 3000);
  EXPECT_GT(rms(u.head(1000)), 0.1);  // not trivially periodic
  for (Eigen::Index k = 0; k < 2000; ++k) {
    ASSERT_EQ(u[k + 1000], u[k]) << "sample " << k + 1000;
  }
}

TEST_F(CliSimulate, MultisineNeedsWholePeriods) {
  const fs::path csv = dir_ / "multisine.csv";
  const RunResult r = run("simulate --signal multisine --period 1000 --samples 2500 --out " + quoted(csv));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "--period")) << r.err;
  EXPECT_FALSE(fs::exists(csv));
}

TEST_F(CliSimulate, WavHoldsTheSameRecordAsCsv) {
  const fs::path csv = dir_ / "run.csv", wav = dir_ / "run.wav";
  expect_result(run("simulate --samples 2000 --seed 5 --out " + quoted(csv)));
  const json result = expect_result(run("simulate --samples 2000 --seed 5 --out " + quoted(wav)));
  EXPECT_EQ(result.value("out", ""), wav.string());

  const dsp::Record from_csv = read_uyix_csv(csv);
  const dsp::Record from_wav = dsp::read_wav(wav, {"u", "y", "i", "x"});
  EXPECT_EQ(from_wav.fs, 3000.0);
  ASSERT_EQ(from_wav.samples(), from_csv.samples());
  for (const char* name : {"u", "y", "i", "x"}) {
    SCOPED_TRACE(name);
    const Eigen::VectorXd& a = from_wav.column(name);
    const Eigen::VectorXd& b = from_csv.column(name);
    for (Eigen::Index k = 0; k < b.size(); ++k) {
      // A float sample holds its double to within half a unit in the last place: 2^-24 relative.
      ASSERT_NEAR(a[k], b[k], std::abs(b[k]) * 1e-7 + 1e-38) << "sample " << k;
    }
  }
}

TEST_F(CliSimulate, PlantFileFromShowSimulatesLikeThePreset) {
  const RunResult show = run("plant show panel-exciter");
  expect_result(show);
  const fs::path plant = file("mine.json", show.out);
  const fs::path a = dir_ / "preset.csv", b = dir_ / "file.csv";
  expect_result(run("simulate --samples 1500 --out " + quoted(a)));
  const json result = expect_result(run("simulate --plant " + quoted(plant) + " --samples 1500 --out " + quoted(b)));
  EXPECT_EQ(result.value("plant", ""), "panel-exciter");
  EXPECT_TRUE(text_of(a) == text_of(b)) << "the shown plant simulates differently from the preset";
}

TEST_F(CliSimulate, SineWithoutFreqFails) {
  const fs::path csv = dir_ / "x.csv";
  const RunResult r = run("simulate --signal sine --samples 100 --out " + quoted(csv));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "--freq")) << r.err;
  EXPECT_FALSE(fs::exists(csv));
}

TEST_F(CliSimulate, PlantFileWithBadKeyNamesFileAndKey) {
  models::PlantConfig preset = models::plant_preset("panel-exciter");
  json plant = models::plant_to_json(preset);
  plant["mechanical"]["masss_kg"] = 0.01;
  const fs::path path = file("typo.json", plant.dump(2));
  const fs::path csv = dir_ / "x.csv";
  const RunResult r = run("simulate --plant " + quoted(path) + " --samples 100 --out " + quoted(csv));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, path.string())) << r.err;
  EXPECT_TRUE(contains(r.err, "plant.mechanical.masss_kg")) << r.err;
  EXPECT_FALSE(fs::exists(csv));
}

TEST_F(CliSimulate, UnwritableOutputFailsNamingThePath) {
  const RunResult r = run("simulate --samples 100 --out /nonexistent-dir/x.csv");
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "/nonexistent-dir/x.csv")) << r.err;
}

TEST_F(CliSimulate, UnknownOutputExtensionFailsNamingThePath) {
  const fs::path out = dir_ / "run.txt";
  const RunResult r = run("simulate --samples 100 --out " + quoted(out));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, out.string())) << r.err;
  EXPECT_TRUE(contains(r.err, ".csv") && contains(r.err, ".wav")) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// ---------------------------------------------------------------------------------------------
// plant

TEST_F(CliPlant, ShowPrintsALoadablePlant) {
  const json result = expect_result(run("plant show panel-exciter"));
  models::PlantConfig shown;
  ASSERT_NO_THROW(shown = models::plant_from_json(result)) << result.dump(2);
  EXPECT_EQ(shown.name, "panel-exciter");
  EXPECT_EQ(result.value("format", ""), "panelbass.plant/1");
  EXPECT_EQ(result, models::plant_to_json(models::plant_preset("panel-exciter")));
}

TEST_F(CliPlant, ShowUnknownPresetListsThePresets) {
  const RunResult r = run("plant show nosuch");
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "nosuch")) << r.err;
  EXPECT_TRUE(contains(r.err, "panel-exciter")) << r.err;
  EXPECT_TRUE(contains(r.err, "linear")) << r.err;
}

// `plant vary` prints the plant with Bl, K, Le and friction each moved by the fraction, not all the same way, and
// refuses a fraction it cannot use.
TEST_F(CliPlant, VaryPrintsALoadableVariantMovedInMixedDirections) {
  const json result = expect_result(run("plant vary panel-exciter --by 0.2 --seed 5"));
  const models::PlantConfig v = models::plant_from_json(result);
  const models::PlantConfig p = models::plant_preset("panel-exciter");
  const double ratios[] = {v.Bl_Tm / p.Bl_Tm, v.stiffness_N_per_m / p.stiffness_N_per_m, v.Le_H / p.Le_H,
                           v.nonlinear.friction.coulomb_N / p.nonlinear.friction.coulomb_N};
  int up = 0;
  for (double r : ratios) {
    EXPECT_NEAR(std::abs(r - 1.0), 0.2, 1e-12) << r;
    up += r > 1.0;
  }
  EXPECT_GT(up, 0);
  EXPECT_LT(up, 4);
  EXPECT_EQ(v.mass_kg, p.mass_kg);
  expect_usage_error(run("plant vary panel-exciter --by 1.5"));
}

TEST_F(CliPlant, SurveyPrintsItsMeasurements) {
  // The only survey run in this suite: the smallest estimation record keeps it quick.
  const RunResult r = run("plant survey panel-exciter --samples 2000 --seed 1");
  ASSERT_EQ(r.status, 0) << "stderr: " << r.err;
  const json result = expect_result(r);
  EXPECT_EQ(result.value("plant", ""), "panel-exciter");
  EXPECT_EQ(result.value("seed", -1), 1);
  for (const char* key : {"delay_samples", "impulse_length_samples", "main_resonance_hz", "upper_resonance_hz",
                          "notch_hz", "notch_depth_db", "J_linear_est_pct", "J_linear_val_pct", "J_noise_pct"}) {
    EXPECT_TRUE(result.contains(key) && result[key].is_number()) << key << " in " << result.dump();
  }
  EXPECT_TRUE(result.contains("distortion") && result["distortion"].is_array()) << result.dump();
}

}  // namespace
}  // namespace panelbass

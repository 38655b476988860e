// `panelbass design mirror` and `evaluate` on its chain, run as a user runs them: a record of panel-exciter,
// the mirror filter fitted to it, the chain, and THD against output level beside the plant alone.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>

#include "models/control/mirror_filter.h"
#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

using namespace testing_support;
using CliDesignMirror = CliTest;

TEST_F(CliDesignMirror, FitsARecordAndItsChainCutsDistortionAtEqualOutputLevel) {
  expect_result(run("simulate --plant panel-exciter --signal multisine --f-min 10 --f-max 300 --amplitude 0.5 "
                    "--samples 12000 --seed 1 --out " + quoted(dir_ / "ident.csv")));
  const json fit = expect_result(run("design mirror --data " + quoted(dir_ / "ident.csv") + " --fs 3000 --out " +
                                     quoted(dir_ / "mirror.json")));
  EXPECT_LT(fit["mechanical_fit_pct"].get<double>(), 1.0);  // [M2] on the plant's own current and motion
  const models::MirrorModel model = models::mirror_model_from_json(json::parse(text_of(dir_ / "mirror.json")));
  EXPECT_EQ(model.fs, 3000.0);
  expect_result(run("chain --bandpass 0,1200 --ff " + quoted(dir_ / "mirror.json") + " --out " + quoted(dir_ / "chain.json")));
  const json e = expect_result(run("evaluate --plant panel-exciter --chain " + quoted(dir_ / "chain.json") +
                                   " --probes 80 --levels 0.3"));
  const json& point = e["level_sweep"]["curves"][0]["points"][0];
  EXPECT_TRUE(point["reachable"].get<bool>());
  // panel-exciter at 80 Hz and program 0.3: 29 % THD alone, about 3 % behind the mirror filter at the same output
  EXPECT_GT(point["cut_db"].get<double>(), 10.0);
  EXPECT_TRUE(e["rows"].empty());  // the Control table needs an LQ feedforward: a mirror chain gets the sweep alone
}

TEST_F(CliDesignMirror, AdaptWritesTheObserverWithTheSensorMapOfTheRecord) {
  expect_result(run("simulate --plant panel-exciter --signal multisine --f-min 10 --f-max 300 --amplitude 0.5 "
                    "--samples 6000 --seed 2 --out " + quoted(dir_ / "ident.csv")));
  const json fit = expect_result(run("design mirror --data " + quoted(dir_ / "ident.csv") + " --fs 3000 --adapt --out " +
                                     quoted(dir_ / "mirror.json")));
  EXPECT_TRUE(fit["adaptive"].get<bool>());
  const models::MirrorModel model = models::mirror_model_from_json(json::parse(text_of(dir_ / "mirror.json")));
  ASSERT_TRUE(model.observer.enabled);
  // [S1]'s residual is the sensor's noise: panel-exciter's sensor adds 0.07 V rms
  EXPECT_NEAR(model.observer.sensor_noise, 0.07, 0.007);
}

TEST_F(CliDesignMirror, CurrentOnlyFitsWithoutTheDisplacementAndItsChainCutsDistortionAtEqualOutputLevel) {
  // the record's x column is dropped: what a sound card records (drive and coil current)
  expect_result(run("simulate --plant panel-exciter --signal multisine --f-min 10 --f-max 300 --amplitude 0.5 "
                    "--samples 12000 --seed 1 --out " + quoted(dir_ / "ident.csv")));
  const std::string full = text_of(dir_ / "ident.csv");
  std::string card;
  for (std::size_t at = 0; at < full.size();) {
    const std::size_t end = full.find('\n', at);
    const std::string line = full.substr(at, end - at);
    // u,y,i,x → u,y,i
    card += line.substr(0, line.rfind(',')) + "\n";
    at = end == std::string::npos ? full.size() : end + 1;
  }
  file("card.csv", card);
  const json fit = expect_result(run("design mirror --data " + quoted(dir_ / "card.csv") + " --fs 3000 --current-only --adapt --out " +
                                     quoted(dir_ / "mirror.json")));
  EXPECT_TRUE(fit["usable"].get<bool>());
  // --adapt with --current-only: the adaptation from the current, at the lag the fit found
  EXPECT_EQ(fit["adapts_from"], "current");
  const json model = json::parse(text_of(dir_ / "mirror.json"));
  EXPECT_EQ(model["params"]["observer"]["measurement"], "current");
  EXPECT_EQ(model["params"]["observer"]["current_lag"], fit["current_lag"]);
  json fixed = model;
  fixed["params"].erase("observer");
  file("mirror-fixed.json", fixed.dump());
  EXPECT_LT(fit["current_j_val_pct"].get<double>(), 0.1);  // the model's free-run current on the record's last 30 %
  EXPECT_LT(fit["current_j_val_pct"].get<double>(), fit["linear_current_j_val_pct"].get<double>());
  expect_result(run("chain --bandpass 0,1200 --ff " + quoted(dir_ / "mirror-fixed.json") + " --out " + quoted(dir_ / "chain.json")));
  const json e = expect_result(run("evaluate --plant panel-exciter --chain " + quoted(dir_ / "chain.json") +
                                   " --probes 80 --levels 0.3"));
  const json& point = e["level_sweep"]["curves"][0]["points"][0];
  EXPECT_TRUE(point["reachable"].get<bool>());
  // panel-exciter at 80 Hz and program 0.3: 29 % THD alone; the current-only chain from these 12000 samples cuts it
  // by 17.7 dB (23.4 dB from 30000 samples, docs/control.md; 7.5 dB before the fit had Le(x)·di/dt); the plant alone
  // would be 0 dB. evaluate feeds a stage the sensor, not the current, so the chain here runs the fixed filter (the
  // adaptation's settings taken out of the model file)
  EXPECT_GT(point["cut_db"].get<double>(), 14.0);
}

TEST_F(CliDesignMirror, CurrentOnlyFitThatMissesWritesNoModel) {
  // a "current" that no drive explains (a pseudo-random sequence beside a sine drive): the fit says it misses and
  // the model is not written
  std::string csv = "u,i\n";
  std::uint32_t state = 12345;
  for (int k = 0; k < 3000; ++k) {
    state = state * 1664525u + 1013904223u;
    const double noise = static_cast<double>(state >> 8) / 16777216.0 - 0.5;
    csv += std::to_string(0.5 * std::sin(0.05 * k)) + "," + std::to_string(noise) + "\n";
  }
  file("noise.csv", csv);
  const RunResult r = run("design mirror --data " + quoted(dir_ / "noise.csv") + " --fs 3000 --current-only --out " +
                          quoted(dir_ / "m.json"));
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_TRUE(contains(r.err, "misses")) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "m.json"));
}

TEST_F(CliDesignMirror, CurrentOnlyNamesABadSensorKind) {
  expect_result(run("simulate --plant linear --signal noise --samples 2000 --seed 1 --out " + quoted(dir_ / "r.csv")));
  const RunResult r = run("design mirror --data " + quoted(dir_ / "r.csv") +
                          " --fs 3000 --current-only --sensor-col y --sensor-kind laser --out " + quoted(dir_ / "m.json"));
  expect_usage_error(r);
  EXPECT_TRUE(contains(r.err, "--sensor-kind")) << r.err;
  EXPECT_TRUE(contains(r.err, "laser")) << r.err;
}

TEST_F(CliDesignMirror, NamesAMissingColumn) {
  expect_result(run("simulate --plant linear --signal noise --samples 2000 --seed 1 --out " + quoted(dir_ / "r.csv")));
  const RunResult r = run("design mirror --data " + quoted(dir_ / "r.csv") + " --fs 3000 --current-col amps --out " +
                          quoted(dir_ / "m.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "amps")) << r.err;
}

}  // namespace
}  // namespace panelbass

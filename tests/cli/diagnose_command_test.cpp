// `panelbass diagnose` run as a user runs it: a linear transducer with a hardening spring simulated by
// `panelbass simulate`, diagnosed end to end; and bad input named.

#include <gtest/gtest.h>

#include "models/plant_config.h"
#include "models/plant_presets.h"
#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

using namespace testing_support;

class CliDiagnose : public CliTest {
 protected:
  /// 24 000 samples of the linear preset with half the panel exciter's cubic stiffness: rows 0..16 000
  /// to estimate, the rest to validate.
  void SetUp() override {
    models::PlantConfig plant = models::plant_preset("linear");
    plant.nonlinear.stiffness.enabled = true;
    plant.nonlinear.stiffness.k1_per_mm = 0.0;
    plant.nonlinear.stiffness.k2_per_mm2 = 0.06;
    plant.nonlinear.stiffness.scale = 0.5;
    file("cubic.json", models::plant_to_json(plant).dump());
    expect_result(run("simulate --plant " + quoted(dir_ / "cubic.json") + " --samples 24000 --seed 3 --out " +
                      quoted(dir_ / "all.csv")));
    split_csv(dir_ / "all.csv", 16000);
  }
  std::string est() const { return quoted(dir_ / "est.csv"); }
  std::string val() const { return quoted(dir_ / "val.csv"); }
};

TEST_F(CliDiagnose, FindsTheCubicSpringAndWritesTheReport) {
  const fs::path out = dir_ / "report.json";
  const RunResult run_result = run("diagnose --data " + est() + " --val " + val() +
                                   " --fs 3000 --scan-from 12 --scan-to 13 --out " + quoted(out));
  const json r = expect_result(run_result);
  EXPECT_TRUE(contains(run_result.err, "diagnose:")) << "progress goes to stderr";
  ASSERT_TRUE(r.contains("findings"));
  ASSERT_FALSE(r["findings"].empty()) << r.dump(1);
  EXPECT_EQ(r["findings"][0]["effect"], "cubic_stiffness");
  EXPECT_LT(r["J_val_after_pct"].get<double>(), r["J_val_before_pct"].get<double>());
  EXPECT_EQ(r["baseline"]["kind"], "linear");
  // The report file: the contract's keys, and the same figures as stdout.
  const json report = json::parse(text_of(out));
  for (const char* key : {"baseline", "findings", "J_val_before_pct", "J_val_after_pct", "noise_floor_pct"})
    EXPECT_TRUE(report.contains(key)) << key;
  for (const char* key : {"effect", "explanation", "evidence", "parameters", "J_val_before_pct", "J_val_after_pct"})
    EXPECT_TRUE(report["findings"][0].contains(key)) << key;
  EXPECT_EQ(report["J_val_after_pct"], r["J_val_after_pct"]);
  EXPECT_EQ(report["baseline"]["J_val_pct"], r["baseline"]["J_val_pct"]);
}

TEST_F(CliDiagnose, BadInputIsNamed) {
  const std::string out = " --out " + quoted(dir_ / "r.json");
  const RunResult missing = run("diagnose --data " + quoted(dir_ / "nope.csv") + " --val " + val() + " --fs 3000" + out);
  expect_failure(missing);
  EXPECT_TRUE(contains(missing.err, "nope.csv")) << missing.err;
  const RunResult column = run("diagnose --data " + est() + " --val " + val() + " --fs 3000 --output-col force" + out);
  expect_failure(column);
  EXPECT_TRUE(contains(column.err, "force")) << column.err;
  const RunResult no_rate = run("diagnose --data " + est() + " --val " + val() + out);
  expect_failure(no_rate);
  EXPECT_TRUE(contains(no_rate.err, "--fs")) << no_rate.err;
  expect_usage_error(run("diagnose --data " + est() + " --val " + val() + " --fs 3000 --scan-from 9 --scan-to 3" + out));
  expect_usage_error(run("diagnose --data " + est() + " --fs 3000" + out));  // --val is required
  EXPECT_FALSE(fs::exists(dir_ / "r.json"));
}

TEST_F(CliDiagnose, HelpHasAnExample) {
  const RunResult r = run("diagnose --help");
  EXPECT_EQ(r.status, 0);
  EXPECT_TRUE(contains(r.out, "Example:")) << r.out;
}

}  // namespace
}  // namespace panelbass

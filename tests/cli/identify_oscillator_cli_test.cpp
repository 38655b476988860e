// `panelbass identify oscillator` run as a user runs it, on a record of a Duffing oscillator made here: the
// model file it writes is read by validate (the J it reports is the J it chose on), analyze and diagnose (as
// the baseline); a bad term list fails naming it.

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "models/oscillator/oscillator_model.h"
#include "models/validation/performance.h"
#include "tests/support/cli_runner.h"
#include "tests/support/noise.h"

namespace panelbass {
namespace {

using namespace testing_support;

/// 5000 samples at 1000 Hz of ÿ + 0.04·ẏ + 0.03·y + 0.5·y³ = 0.06·ũ (time in samples) with 1e-3 output noise:
/// rows 0..3000 in est.csv, the rest in val.csv; `clean_` keeps the noiseless validation output.
class CliIdentifyOscillator : public CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    models::OscillatorStructure s;
    s.terms = {models::OscillatorTerm::y3};
    Eigen::VectorXd theta = Eigen::VectorXd::Zero(s.parameter_count());
    theta(models::kOscDamping) = 0.04;
    theta(models::kOscStiffness) = 0.03;
    theta(models::kOscGain) = 0.06;
    theta(s.term_index(0)) = 0.5;
    const Eigen::VectorXd u = uniform_noise(5000, 0.4, 21);
    const Eigen::VectorXd clean = models::oscillator_run(s, theta, models::BandLimitedInput(u), Eigen::Vector2d::Zero(),
                                                         models::OscillatorSensitivity::none).y;
    const Eigen::VectorXd y = clean + gaussian(5000, 1e-3, 22);
    std::ofstream out(dir_ / "all.csv");
    out.precision(17);
    out << "u,y\n";
    for (Eigen::Index k = 0; k < u.size(); ++k) out << u(k) << "," << y(k) << "\n";
    out.close();
    split_csv(dir_ / "all.csv", 3000);
    clean_ = clean.tail(2000);
    y_val_ = y.tail(2000);
  }
  std::string est() const { return quoted(dir_ / "est.csv"); }
  std::string val() const { return quoted(dir_ / "val.csv"); }
  Eigen::VectorXd clean_, y_val_;
};

TEST_F(CliIdentifyOscillator, ItsModelIsReadByValidateAnalyzeAndDiagnose) {
  const fs::path model = dir_ / "osc.json";
  const json r = expect_result(run("identify oscillator --data " + est() + " --val " + val() +
                                   " --fs 1000 --terms y3,v_y2 --out " + quoted(model)));
  ASSERT_EQ(r["stages"].size(), 3u) << "linear, then one stage per term";
  EXPECT_EQ(r["stages"][0]["stage"], "linear");
  EXPECT_EQ(r["stages"][1]["stage"], "y3");
  // Chosen by the lowest J_val, and down to the noise floor with the cubic spring.
  double lowest = 1e300;
  for (const json& s : r["stages"]) lowest = std::min(lowest, s["J_val_pct"].get<double>());
  EXPECT_EQ(r["J_val_pct"].get<double>(), lowest);
  EXPECT_EQ(r["warnings"], json::array()) << "a good fit warns of nothing";
  EXPECT_LT(r["J_val_pct"].get<double>(), 1.2 * models::j_percent(clean_, y_val_, 50));
  const json v = expect_result(run("validate --model " + quoted(model) + " --data " + val() + " --init 50"));
  EXPECT_EQ(v["kind"], "oscillator");
  EXPECT_NEAR(v["J_sim_pct"].get<double>(), r["J_val_pct"].get<double>(), 1e-9) << "the J chosen on is the J validate gives";
  const json a = expect_result(run("analyze --model " + quoted(model) + " --data " + val() + " --out " + quoted(dir_ / "a.json")));
  EXPECT_EQ(a["kind"], "oscillator");
  expect_result(run("diagnose --data " + est() + " --val " + val() + " --model " + quoted(model) +
                    " --max-findings 1 --out " + quoted(dir_ / "d.json")));
  const json baseline = json::parse(text_of(dir_ / "d.json"))["baseline"];
  EXPECT_EQ(baseline["kind"], "oscillator");
  EXPECT_NEAR(baseline["J_val_pct"].get<double>(), v["J_sim_pct"].get<double>(), 1e-9);
}

TEST_F(CliIdentifyOscillator, AFitThatMissesMostOfTheOutputSaysSo) {
  // The panel exciter's recorded output is not one mass on a spring: the fit is written, with a warning.
  expect_result(run("simulate --samples 6000 --seed 5 --out " + quoted(dir_ / "pe.csv")));
  split_csv(dir_ / "pe.csv", 4000);
  const RunResult run_result = run("identify oscillator --data " + est() + " --val " + val() + " --fs 3000 --terms y3 --out " +
                                   quoted(dir_ / "pe.json"));
  const json r = expect_result(run_result);
  ASSERT_GT(r["J_val_pct"].get<double>(), 10.0);
  ASSERT_GE(r["warnings"].size(), 1u);
  for (const json& w : r["warnings"]) EXPECT_NE(w.get<std::string>().find("not be one mass on a spring"), std::string::npos) << w;
  EXPECT_NE(run_result.err.find("identify oscillator: warning: "), std::string::npos) << run_result.err;
}

TEST_F(CliIdentifyOscillator, AnUnknownTermFailsNamingIt) {
  const RunResult r = run("identify oscillator --data " + est() + " --fs 1000 --terms y3,z9 --out " + quoted(dir_ / "m.json"));
  expect_usage_error(r);  // a bad option (exit 2), named as the API names params.terms
  EXPECT_NE(r.err.find("--terms: unknown oscillator term \"z9\""), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "m.json"));
}

}  // namespace
}  // namespace panelbass

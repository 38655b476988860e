// `panelbass analyze` run as a user runs it: a linear OE model identified on simulated data is analysed,
// the JSON has every part, the figures are PNG (or SVG) files, and the HTML page embeds each of them
// byte for byte (checked against coreutils' `base64`, an independent encoder); bad input fails with one
// error line; a missing gnuplot is named with its package.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <set>
#include <string>

#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

using namespace testing_support;

/// 6000 samples of the panel exciter: rows 0..4000 identify an 8th-order OE model, the rest are analysed.
class CliAnalyze : public CliTest {
 protected:
  void SetUp() override {
    expect_result(run("simulate --samples 6000 --seed 5 --out " + quoted(dir_ / "all.csv")));
    split_csv(dir_ / "all.csv", 4000);
    expect_result(run("identify linear --data " + quoted(dir_ / "est.csv") +
                      " --fs 3000 --method oe --order 8 --out " + quoted(dir_ / "lin.json")));
  }
  std::string model() const { return quoted(dir_ / "lin.json"); }
  std::string val() const { return quoted(dir_ / "val.csv"); }

  /// How often `part` occurs in `text`.
  static std::size_t count(const std::string& text, const std::string& part) {
    std::size_t n = 0;
    for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + part.size())) ++n;
    return n;
  }

  /// The file's base64 by coreutils (no line wrapping).
  std::string coreutils_base64(const fs::path& path) {
    const fs::path out = dir_ / "b64.txt";
    const int rc = std::system(("base64 -w0 " + quoted(path) + " >" + quoted(out)).c_str());
    EXPECT_EQ(rc, 0);
    return text_of(out);
  }
};

TEST_F(CliAnalyze, LinearModelReportHasEveryPartAndEmbedsEveryFigure) {
  const fs::path html = dir_ / "report.html", out = dir_ / "report.json", plots = dir_ / "plots";
  const json r = expect_result(run("analyze --model " + model() + " --data " + val() +
                                   " --fs 3000 --init 50 --plant panel-exciter --freqs 80,160,320 --measure 1000"
                                   " --out " + quoted(out) + " --html " + quoted(html) + " --plots " + quoted(plots)));
  for (const char* key : {"J_sim_pct", "J_pred_pct", "rmse", "J_noncoherent_pct", "J_noise_pct", "residual_tests",
                          "residual_spectrum", "frf", "poles", "zeros", "root_locus", "training_history", "distortion",
                          "plots", "html", "out"}) {
    EXPECT_TRUE(r.contains(key) && !r[key].is_null()) << key;
  }
  // The same J as `validate` (same protocol: 50 measured outputs set the state).
  const json v = expect_result(run("validate --model " + model() + " --data " + val() + " --init 50"));
  EXPECT_NEAR(r["J_sim_pct"].get<double>(), v["J_sim_pct"].get<double>(), 1e-9);
  EXPECT_NEAR(r["J_pred_pct"].get<double>(), v["J_pred_pct"].get<double>(), 1e-9);
  // J of the sensor noise is a floor under any model's J.
  EXPECT_LT(r["J_noise_pct"].get<double>(), r["J_sim_pct"].get<double>());

  const json& tests = r["residual_tests"]["tests"];
  ASSERT_EQ(tests.size(), 5u);
  std::set<std::string> names;
  for (const json& t : tests) {
    names.insert(t["name"].get<std::string>());
    EXPECT_TRUE(t["verdict"] == "pass" || t["verdict"] == "fail");
    EXPECT_GT(t["band"].get<double>(), 0.0);
  }
  EXPECT_EQ(names, (std::set<std::string>{"phi_ee", "phi_ue", "phi_u2e", "phi_u2e2", "phi_e_eu"}));
  const std::string explanation = r["residual_tests"]["explanation"];
  EXPECT_FALSE(explanation.empty());
  // A linear model of a distorting plant far above its sensor noise: the residual is called model error,
  // never "no model error", and a coherence figure the model beats is not called a floor.
  EXPECT_FALSE(contains(explanation, "no model error")) << explanation;
  const double j_sim = r["J_sim_pct"], j_noise = r["J_noise_pct"], j_noncoherent = r["J_noncoherent_pct"];
  EXPECT_EQ(contains(explanation, "mostly model error"), j_sim > 3.0 * j_noise) << explanation;
  EXPECT_EQ(contains(explanation, "no floor here"), j_sim < j_noncoherent) << explanation;

  const json& spectrum = r["residual_spectrum"];
  EXPECT_EQ(spectrum["frequency_hz"].size(), spectrum["residual_psd"].size());
  EXPECT_EQ(spectrum["frequency_hz"].size(), spectrum["noncoherent_psd"].size());
  EXPECT_EQ(r["frf"]["coherence"].size(), r["frf"]["measured_db"].size());
  EXPECT_GT(r["frf"]["mean_coherence"].get<double>(), 0.5);

  EXPECT_EQ(r["poles"].size(), 8u);
  const json& locus = r["root_locus"];
  EXPECT_TRUE(locus["best"]["stable"].get<bool>());
  // The gain found shortens the badly damped plant's impulse response (thesis fig. 4.2).
  EXPECT_LT(locus["best"]["impulse_length"].get<double>(), locus["open_loop"]["impulse_length"].get<double>());
  EXPECT_GE(locus["best"]["gain"].get<double>(), locus["gain_min"].get<double>());
  EXPECT_LE(locus["best"]["gain"].get<double>(), locus["gain_max"].get<double>());
  EXPECT_GE(r["training_history"]["points"].size(), 1u);
  EXPECT_EQ(r["distortion"]["plant"].size(), 3u);
  EXPECT_EQ(r["distortion"]["model"].size(), 3u);

  // --out holds the object printed.
  EXPECT_EQ(json::parse(text_of(out)), r);

  // Every figure is a PNG file, and the page embeds each of them byte for byte.
  const std::string page = text_of(html);
  ASSERT_FALSE(page.empty());
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_FALSE(contains(page, "src=\"http")) << "the page must not load external assets";
  const std::set<std::string> expected{"time", "psd", "frf", "residual_tests", "poles_zeros", "training", "harmonics-1"};
  std::set<std::string> plotted;
  for (const auto& [name, path] : r["plots"].items()) {
    plotted.insert(name);
    const std::string png = text_of(path.get<std::string>());
    EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << path;
    EXPECT_TRUE(contains(page, "<img src=\"data:image/png;base64," + coreutils_base64(path.get<std::string>()) + "\""))
        << name << " is not embedded";
    // The script and data stay next to the image, so the figure can be redrawn.
    EXPECT_TRUE(fs::exists(plots / (name + ".gp"))) << name;
    EXPECT_TRUE(fs::exists(plots / (name + ".dat"))) << name;
  }
  EXPECT_EQ(plotted, expected);
  EXPECT_EQ(count(page, "<img src=\"data:image/png;base64,"), expected.size());
  EXPECT_TRUE(contains(page, "id=\"training\"")) << "the J-per-iteration figure is missing";
}

TEST_F(CliAnalyze, HtmlAloneWithSvgFiguresAndNoPlant) {
  const fs::path html = dir_ / "r.html";
  const json r = expect_result(run("analyze --model " + model() + " --data " + val() + " --fs 3000 --plot-format svg" +
                                   " --out " + quoted(dir_ / "r.json") + " --html " + quoted(html)));
  EXPECT_TRUE(r["plots"].is_null());
  EXPECT_TRUE(r["distortion"].is_null());
  EXPECT_TRUE(r["J_noise_pct"].is_null());
  const std::string page = text_of(html);
  // time, psd, frf, residual tests, poles/zeros, J per iteration
  EXPECT_EQ(count(page, "<img src=\"data:image/svg+xml;base64,"), 6u);
  // Only the files asked for: the figures of an HTML-only report were drawn in a scratch directory.
  std::set<std::string> left;
  for (const auto& entry : fs::directory_iterator(dir_)) left.insert(entry.path().filename().string());
  for (const char* name : {"r.html", "r.json", "lin.json", "all.csv", "est.csv", "val.csv"}) left.erase(name);
  for (auto it = left.begin(); it != left.end();) it = it->rfind("std", 0) == 0 ? left.erase(it) : std::next(it);
  EXPECT_TRUE(left.empty()) << *left.begin();
}

TEST_F(CliAnalyze, NarxModelWithItsTrainingLog) {
  const fs::path log = dir_ / "narx.log.json";
  const RunResult trained = run("identify narx --data " + quoted(dir_ / "est.csv") +
                                " --fs 3000 --na 2 --nb 2 --hidden 3 --max-iter 3 --out " + quoted(dir_ / "nn.json") +
                                " --history " + quoted(log));
  expect_result(trained);
  const json t = json::parse(text_of(log));
  const json r = expect_result(run("analyze --model " + quoted(dir_ / "nn.json") + " --data " + val() + " --fs 3000" +
                                   " --history " + quoted(log) + " --out " + quoted(dir_ / "r.json") + " --plots " +
                                   quoted(dir_ / "p")));
  EXPECT_EQ(r["kind"], "narx");
  EXPECT_TRUE(r["root_locus"].is_null());
  EXPECT_TRUE(r["poles"].is_null());
  EXPECT_EQ(r["training_history"]["points"].size(), t["history"].size());
  EXPECT_TRUE(contains(r["training_history"]["source"].get<std::string>(), "narx.log.json"));
  EXPECT_TRUE(r["plots"].contains("training"));
  EXPECT_FALSE(r["plots"].contains("poles_zeros"));
}

TEST_F(CliAnalyze, MissingModelFailsWithOneLine) {
  const RunResult r = run("analyze --model " + quoted(dir_ / "nope.json") + " --data " + val() + " --fs 3000 --out " +
                          quoted(dir_ / "r.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "nope.json")) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "r.json"));
}

TEST_F(CliAnalyze, WrongKindFailsWithOneLine) {
  // A plant file is no model.
  const RunResult plant = run("plant show panel-exciter");
  file("plant.json", plant.out);
  const RunResult r = run("analyze --model " + quoted(dir_ / "plant.json") + " --data " + val() + " --out " +
                          quoted(dir_ / "r.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "plant.json")) << r.err;
  // Nor is a model file of an unknown kind.
  json m = json::parse(text_of(dir_ / "lin.json"));
  m["kind"] = "banana";
  file("banana.json", m.dump());
  const RunResult k = run("analyze --model " + quoted(dir_ / "banana.json") + " --data " + val() + " --out " +
                          quoted(dir_ / "r.json"));
  expect_failure(k);
  EXPECT_TRUE(contains(k.err, "banana")) << k.err;
}

TEST_F(CliAnalyze, BadDataAndUsage) {
  // A rate that is not the model's.
  expect_failure(run("analyze --model " + model() + " --data " + val() + " --fs 8000 --out " + quoted(dir_ / "r.json")));
  // --init as long as the data: a usage error naming the flag (usecases/analyze.h).
  const RunResult init = run("analyze --model " + model() + " --data " + val() + " --init 2000 --out " + quoted(dir_ / "r.json"));
  expect_usage_error(init);
  EXPECT_TRUE(contains(init.err, "--init: 2000 is not shorter than the data")) << init.err;
  // --out in a directory that does not exist.
  expect_failure(run("analyze --model " + model() + " --data " + val() + " --out " + quoted(dir_ / "no" / "r.json")));
  // No --out.
  expect_usage_error(run("analyze --model " + model() + " --data " + val()));
}

TEST_F(CliAnalyze, MissingGnuplotIsNamedWithItsPackage) {
  const std::string saved = std::getenv("PATH") != nullptr ? std::getenv("PATH") : "";
  fs::create_directories(dir_ / "empty-bin");
  ::setenv("PATH", (dir_ / "empty-bin").c_str(), 1);
  const RunResult with_html = run("analyze --model " + model() + " --data " + val() + " --out " +
                                  quoted(dir_ / "r.json") + " --html " + quoted(dir_ / "r.html"));
  const RunResult without = run("analyze --model " + model() + " --data " + val() + " --out " + quoted(dir_ / "s.json"));
  ::setenv("PATH", saved.c_str(), 1);
  expect_failure(with_html);
  EXPECT_TRUE(contains(with_html.err, "gnuplot-nox")) << with_html.err;
  EXPECT_FALSE(fs::exists(dir_ / "r.html"));
  // Without figures nothing needs gnuplot.
  expect_result(without);
}

}  // namespace
}  // namespace panelbass

// `panelbass diagnose` run as a user runs it: a linear transducer with a hardening spring simulated by
// `panelbass simulate`, diagnosed end to end, with its HTML report and figures; and bad input named.

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>

#include "models/plant/plant_config.h"
#include "models/plant/plant_presets.h"
#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

using namespace testing_support;

class CliDiagnose : public CliTest {
 protected:
  /// 24 000 samples of the linear preset with a tenth of the panel exciter's cubic stiffness: rows 0..16 000
  /// to estimate, the rest to validate.
  void SetUp() override {
    models::PlantConfig plant = models::plant_preset("linear");
    plant.nonlinear.stiffness.enabled = true;
    plant.nonlinear.stiffness.k1_per_mm = 0.0;
    plant.nonlinear.stiffness.k2_per_mm2 = 0.06;
    plant.nonlinear.stiffness.scale = 0.1;
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
  // Stiffness acts on displacement: the explanation names it, never the velocity alone.
  const std::string why = r["findings"][0]["explanation"];
  EXPECT_TRUE(contains(why, "displacement")) << why;
  EXPECT_FALSE(contains(why, "(a velocity")) << why;
  // The plant has the linear preset's one sample of delay and the baseline found it: no delay finding.
  EXPECT_EQ(r["baseline"]["nk"], 1) << r["baseline"];
  for (const auto& f : r["findings"]) {
    EXPECT_NE(f["effect"], "delay") << f["explanation"];
    EXPECT_FALSE(contains(f["explanation"].get<std::string>(), "1.0 times larger")) << f["explanation"];
  }
  EXPECT_LT(r["J_val_after_pct"].get<double>(), r["J_val_before_pct"].get<double>());
  EXPECT_EQ(r["baseline"]["kind"], "linear");
  // `simulate` writes the coil current (column i) in both records: used by default (--current-col auto).
  EXPECT_EQ(r["channels"], json::parse(R"(["drive", "output", "current"])")) << r.dump(1);
  // The report file: the contract's keys, and the same figures as stdout.
  const json report = json::parse(text_of(out));
  for (const char* key : {"baseline", "findings", "J_val_before_pct", "J_val_after_pct", "noise_floor_pct"})
    EXPECT_TRUE(report.contains(key)) << key;
  for (const char* key : {"effect", "explanation", "evidence", "parameters", "J_val_before_pct", "J_val_after_pct"})
    EXPECT_TRUE(report["findings"][0].contains(key)) << key;
  EXPECT_EQ(report["J_val_after_pct"], r["J_val_after_pct"]);
  EXPECT_EQ(report["baseline"]["J_val_pct"], r["baseline"]["J_val_pct"]);
}

TEST_F(CliDiagnose, HtmlReportShowsTheFindingsAndEmbedsEveryFigure) {
  const fs::path out = dir_ / "report.json", html = dir_ / "report.html", plots = dir_ / "plots";
  const json r = expect_result(run("diagnose --data " + est() + " --val " + val() +
                                   " --fs 3000 --scan-from 12 --scan-to 13 --max-findings 1 --out " + quoted(out) +
                                   " --html " + quoted(html) + " --plots " + quoted(plots)));
  ASSERT_FALSE(r["findings"].empty()) << r.dump(1);
  EXPECT_EQ(r["html"], html.string());
  // The report file names the page and the figures too.
  const json report = json::parse(text_of(out));
  EXPECT_EQ(report["html"], r["html"]);
  EXPECT_EQ(report["plots"], r["plots"]);

  // The figures: the residual spectrum, the fit, J per step, and the cubic spring's term against its state.
  ASSERT_TRUE(r["plots"].is_object()) << r.dump(1);
  std::set<std::string> plotted;
  for (const auto& [name, path] : r["plots"].items()) {
    plotted.insert(name);
    EXPECT_EQ(text_of(path.get<std::string>()).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << path;
    EXPECT_TRUE(fs::exists(plots / (name + ".gp"))) << name;
    EXPECT_TRUE(fs::exists(plots / (name + ".dat"))) << name;
  }
  for (const char* name : {"residual_spectrum", "fit", "j_per_step", "residual_vs_state"}) EXPECT_TRUE(plotted.count(name)) << name;
  // One figure per gray-box term of the final model (the last finding's terms), named after its effect and
  // state, its scatter thinned to a few thousand points (the validation record has 8000 samples).
  const json& terms = report["findings"].back()["parameters"]["terms"];
  ASSERT_TRUE(terms.is_array()) << report["findings"].back().dump(1);
  std::size_t term_figures = 0;
  for (std::size_t i = 0; i < terms.size(); ++i) {
    const std::string name = "term-" + std::to_string(i + 1);
    if (!plotted.count(name)) continue;
    ++term_figures;
    const std::string script = text_of(plots / (name + ".gp")), data = text_of(plots / (name + ".dat"));
    EXPECT_TRUE(contains(script, terms[i]["effect"].get<std::string>())) << script;
    EXPECT_TRUE(contains(script, terms[i]["state"].get<std::string>())) << script;
    EXPECT_LE(std::count(data.begin(), data.end(), '\n'), 3000);
    EXPECT_GE(std::count(data.begin(), data.end(), '\n'), 1000);
  }
  EXPECT_GE(term_figures, 1u) << "the spring is a gray-box term: " << terms.dump();

  // The page reads on its own: the baseline, the findings with J before and after, every figure embedded.
  const std::string page = text_of(html);
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_FALSE(contains(page, "src=\"http")) << "the page must not load external assets";
  for (const char* part : {"<h2>Baseline</h2>", "<h2>Findings</h2>", "noise floor", "J before", "J after",
                           "channels used</th><td>drive, output, current<"})
    EXPECT_TRUE(contains(page, part)) << part;
  EXPECT_TRUE(contains(page, "<code>" + r["findings"][0]["effect"].get<std::string>() + "</code>"));
  std::size_t images = 0;
  for (std::size_t at = page.find("<img src=\"data:image/png;base64,"); at != std::string::npos;
       at = page.find("<img src=\"data:image/png;base64,", at + 1))
    ++images;
  EXPECT_EQ(images, plotted.size());
  for (const std::string& name : plotted) EXPECT_TRUE(contains(page, "<figure id=\"" + name + "\"")) << name;
}

// With --current-col the force channel is used (the file's column i) and says so; on this visible spring the
// states of its force features come from the output the current explains (not from the drive's linear model, whose
// phase near the shifted resonance made v³ look better than x³): the spring is still named, and not ambiguous.
TEST_F(CliDiagnose, TheCurrentOptedInStillNamesAVisibleCubicSpring) {
  const fs::path out = dir_ / "report.json";
  const json r = expect_result(run("diagnose --data " + est() + " --val " + val() +
                                   " --fs 3000 --scan-from 12 --scan-to 13 --max-findings 1 --current-col auto --out " +
                                   quoted(out)));
  EXPECT_EQ(r["channels"], json::parse(R"(["drive", "output", "current"])")) << r.dump(1);
  const json report = json::parse(text_of(out));
  ASSERT_FALSE(report["findings"].empty()) << r.dump(1);
  const json& first = report["findings"][0];
  EXPECT_EQ(first["effect"], "cubic_stiffness") << first["confidence"].dump(1);
  EXPECT_NE(first["confidence"]["word"], "ambiguous") << first["confidence"].dump(1) << first["evidence"]["current_channel"].dump(1);
}

// --model may name a simulation that is not linear: here the virtual transducer without the spring. Against
// a fixed baseline the hardening spring also raises the resonance at this drive level, so a linear refit of
// the resonance may come first; the cubic spring must be among the findings.
TEST_F(CliDiagnose, APlantBaselineIsDiagnosedThroughItsLinearisation) {
  file("plain.json", models::plant_to_json(models::plant_preset("linear")).dump());
  const json r = expect_result(run("diagnose --data " + est() + " --val " + val() + " --model " +
                                   quoted(dir_ / "plain.json") + " --max-findings 3 --out " +
                                   quoted(dir_ / "report.json")));
  EXPECT_EQ(r["baseline"]["kind"], "plant");
  EXPECT_TRUE(r["baseline"].contains("linearisation")) << r["baseline"].dump(1);
  std::set<std::string> effects;
  for (const auto& f : r["findings"]) effects.insert(f["effect"].get<std::string>());
  EXPECT_TRUE(effects.count("cubic_stiffness")) << r["findings"].dump(1);
  EXPECT_LT(r["J_val_after_pct"].get<double>(), r["J_val_before_pct"].get<double>());
}

// A NARX model as the baseline: its J before is the J `validate` gives it (same records, same init).
TEST_F(CliDiagnose, ANarxBaselineStartsFromItsOwnSimulation) {
  expect_result(run("identify narx --data " + est() + " --fs 3000 --na 2 --nb 2 --hidden 3 --max-iter 3 --out " +
                    quoted(dir_ / "nn.json")));
  const json v = expect_result(run("validate --model " + quoted(dir_ / "nn.json") + " --data " + val() + " --init 50"));
  const json r = expect_result(run("diagnose --data " + est() + " --val " + val() + " --model " + quoted(dir_ / "nn.json") +
                                   " --max-findings 1 --out " + quoted(dir_ / "report.json")));
  EXPECT_EQ(r["baseline"]["kind"], "narx");
  EXPECT_NEAR(r["J_val_before_pct"].get<double>(), v["J_sim_pct"].get<double>(), 1e-6 * v["J_sim_pct"].get<double>());
  EXPECT_LE(r["J_val_after_pct"].get<double>(), r["J_val_before_pct"].get<double>());
}

// --model-out: the diagnosed model (the linear baseline and its gray-box terms) as a model file that validate and
// analyze read; its J on the validation record is the diagnosis's J after (the same simulation, the same init).
TEST_F(CliDiagnose, ModelOutWritesTheDiagnosedModelThatValidateReads) {
  const fs::path model = dir_ / "diagnosed.json";
  const json r = expect_result(run("diagnose --data " + est() + " --val " + val() + " --fs 3000 --scan-from 12 --scan-to 13 " +
                                   "--max-findings 1 --out " + quoted(dir_ / "report.json") + " --model-out " + quoted(model)));
  ASSERT_FALSE(r["findings"].empty()) << r.dump(1);
  EXPECT_EQ(r["model_out"], model.string());
  const json file_json = json::parse(text_of(model));
  EXPECT_EQ(file_json["kind"], "gray_box");
  EXPECT_EQ(file_json["terms"].size(), 1u) << file_json["terms"].dump(1);
  EXPECT_EQ(file_json["terms"][0]["effect"], r["findings"][0]["effect"]);
  const json v = expect_result(run("validate --model " + quoted(model) + " --data " + val() + " --init 50"));
  EXPECT_EQ(v["kind"], "gray_box");
  const double j_after = r["J_val_after_pct"].get<double>();
  EXPECT_NEAR(v["J_sim_pct"].get<double>(), j_after, 1e-9 * j_after);
  const json a = expect_result(run("analyze --model " + quoted(model) + " --data " + val() + " --init 50 --out " +
                                   quoted(dir_ / "analysis.json")));
  EXPECT_NEAR(a["J_sim_pct"].get<double>(), j_after, 1e-9 * j_after) << a.dump(1).substr(0, 2000);
  // The controller design takes its linear part.
  expect_result(run("design lq --model " + quoted(model) + " --R 1e-3 --R0 20 --out " + quoted(dir_ / "ff.json")));
  EXPECT_TRUE(fs::exists(dir_ / "ff.json"));
}

// Only a linear baseline's diagnosis is a model file: another baseline is refused before the work.
TEST_F(CliDiagnose, ModelOutOfANonLinearBaselineIsRefusedBeforeTheWork) {
  file("plain.json", models::plant_to_json(models::plant_preset("linear")).dump());
  const RunResult r = run("diagnose --data " + est() + " --val " + val() + " --model " + quoted(dir_ / "plain.json") +
                          " --out " + quoted(dir_ / "r.json") + " --model-out " + quoted(dir_ / "m.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "--model-out")) << r.err;
  EXPECT_FALSE(contains(r.err, "diagnose: simulating")) << "refused only after the work: " << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "m.json"));
}

TEST_F(CliDiagnose, HtmlIntoAMissingFolderIsRefusedBeforeTheWork) {
  const fs::path missing = dir_ / "no-such-folder" / "r.html";
  const RunResult r = run("diagnose --data " + est() + " --val " + val() + " --fs 3000 --out " +
                          quoted(dir_ / "r.json") + " --html " + quoted(missing));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "--html")) << r.err;
  EXPECT_TRUE(contains(r.err, "does not exist")) << r.err;
  EXPECT_FALSE(contains(r.err, "diagnose: identifying")) << "refused only after the work: " << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "r.json"));
  EXPECT_FALSE(fs::exists(missing.parent_path()));
  expect_usage_error(run("diagnose --data " + est() + " --val " + val() + " --fs 3000 --out " + quoted(dir_ / "r.json") +
                         " --html " + quoted(dir_ / "r.html") + " --plot-format gif"));
  EXPECT_FALSE(fs::exists(dir_ / "r.html"));
}

// Records at two drive levels (--data and --val repeated): the loud pair is diagnosed, and the spring's gain in J,
// judged on the quiet pair's validation part too, grows with the level.
TEST_F(CliDiagnose, RecordsAtTwoLevelsSayTheSpringsGainGrowsWithTheDrive) {
  fs::rename(dir_ / "est.csv", dir_ / "loud-est.csv");
  fs::rename(dir_ / "val.csv", dir_ / "loud-val.csv");
  expect_result(run("simulate --plant " + quoted(dir_ / "cubic.json") + " --samples 24000 --amplitude 0.4 --seed 4 --out " +
                    quoted(dir_ / "quiet.csv")));
  split_csv(dir_ / "quiet.csv", 16000);
  const fs::path out = dir_ / "levels.json";
  // The quiet pair first: the loud one is still the one diagnosed.
  const json r = expect_result(run("diagnose --data " + est() + " --val " + val() + " --data " + quoted(dir_ / "loud-est.csv") +
                                   " --val " + quoted(dir_ / "loud-val.csv") + " --fs 3000 --scan-from 12 --scan-to 13 " +
                                   "--max-findings 1 --out " + quoted(out)));
  const json report = json::parse(text_of(out));
  ASSERT_EQ(report["levels"].size(), 2u) << report["levels"];
  EXPECT_FALSE(report["levels"][0]["diagnosed"].get<bool>());
  EXPECT_TRUE(report["levels"][1]["diagnosed"].get<bool>());
  EXPECT_TRUE(contains(report["val"].get<std::string>(), "loud-val.csv")) << report["val"];
  ASSERT_FALSE(report["findings"].empty()) << r.dump(1);
  const json& levels = report["findings"][0]["evidence"]["levels"];
  ASSERT_EQ(levels["records"].size(), 2u) << levels.dump(1);
  EXPECT_TRUE(levels["grows_with_level"].get<bool>()) << levels.dump(1);
  // Unpaired records are refused before the work.
  expect_usage_error(run("diagnose --data " + est() + " --data " + est() + " --val " + val() + " --fs 3000 --out " +
                         quoted(dir_ / "r.json")));
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
  EXPECT_TRUE(contains(r.out, "--html report.html")) << r.out;
}

}  // namespace
}  // namespace panelbass

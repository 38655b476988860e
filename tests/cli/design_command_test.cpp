// `panelbass design lq` run as a user runs it: simulate, identify a linear model, design the LQ
// feedforward controller, and read the controller file back.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "dsp/butterworth.h"
#include "models/linear/linear_model.h"
#include "models/control/lq_feedforward.h"
#include "models/linear/state_space.h"
#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

using namespace testing_support;
using CliDesign = CliTest;

class CliDesignModel : public CliTest {
 protected:
  /// A 6th-order OE model of the panel exciter from 4000 samples of noise.
  void SetUp() override {
    expect_result(run("simulate --plant panel-exciter --signal noise --samples 4000 --seed 3 --out " +
                      quoted(dir_ / "run.csv")));
    expect_result(run("identify linear --data " + quoted(dir_ / "run.csv") + " --fs 3000 --method oe --order 6 --out " +
                      quoted(model())));
  }
  fs::path model() const { return dir_ / "lin.json"; }
};

TEST_F(CliDesignModel, LqPrintsTheContractAndWritesAControllerThatLoadsBack) {
  const fs::path out = dir_ / "ff.json";
  const json r = expect_result(run("design lq --model " + quoted(model()) + " --R 3 --R0 20 --bandpass 20,1200 --samples 20000 --out " +
                                   quoted(out)));
  for (const char* key : {"L", "poles", "zeros", "max_input_worst", "max_input_noise", "bandpass", "order", "ripple_db"}) {
    EXPECT_TRUE(r.contains(key)) << key;
  }
  // The model's order: max(na, nk + nb − 1) states of its realisation.
  const json lin = json::parse(text_of(model()));
  const int na = static_cast<int>(lin["params"]["a"].size()), nb = static_cast<int>(lin["params"]["b"].size());
  const int order = std::max(na, lin["params"]["nk"].get<int>() + nb - 1);
  EXPECT_EQ(r["order"], order);
  ASSERT_EQ(r["L"].size(), static_cast<std::size_t>(order));
  for (const auto& l : r["L"]) EXPECT_TRUE(std::isfinite(l.get<double>()));
  ASSERT_EQ(r["poles"].size(), static_cast<std::size_t>(order));
  for (const auto& p : r["poles"]) EXPECT_LT(std::hypot(p[0].get<double>(), p[1].get<double>()), 1.0);
  const double worst = r["max_input_worst"], noise = r["max_input_noise"];
  EXPECT_GT(worst, 0.0);
  EXPECT_GE(noise, worst);
  EXPECT_EQ(r["bandpass"], json::array({20.0, 1200.0}));

  const models::LqFeedforward ff = models::lq_feedforward_from_json(json::parse(text_of(out)));
  EXPECT_EQ(ff.L.size(), order);
  EXPECT_EQ(ff.weights.R, 3.0);
  EXPECT_EQ(ff.weights.R0, 20.0);
  EXPECT_EQ(ff.fs, 3000.0);
  for (Eigen::Index i = 0; i < ff.L.size(); ++i) EXPECT_EQ(ff.L[i], r["L"][static_cast<std::size_t>(i)].get<double>());
  EXPECT_EQ(ff.meta["model"], model().string());
  EXPECT_EQ(ff.meta["bandpass"], json::array({20.0, 1200.0}));
  EXPECT_EQ(ff.meta["weights"]["R"], 3.0);
  // The controller file gives back the printed limits.
  const models::InputLimits limits =
      models::max_input(ff, dsp::butterworth_bandpass(2, 20.0, 1200.0, 3000.0), 20000, 1);
  EXPECT_NEAR(limits.worst, worst, 1e-12 * worst);
  EXPECT_NEAR(limits.noise, noise, 1e-12 * noise);
}

TEST_F(CliDesignModel, CheapControlFlattensTheResponseAndNeedsASmallerInput) {
  const json expensive = expect_result(run("design lq --model " + quoted(model()) +
                                           " --R 3 --R0 20 --bandpass 0,1200 --samples 20000 --out " + quoted(dir_ / "a.json")));
  const json cheap = expect_result(run("design lq --model " + quoted(model()) +
                                       " --R 1e-5 --R0 20 --bandpass 0,1200 --samples 20000 --out " + quoted(dir_ / "b.json")));
  EXPECT_EQ(cheap["bandpass"], json::array({0.0, 1200.0}));
  EXPECT_LT(cheap["ripple_db"]["controlled"].get<double>(), expensive["ripple_db"]["controlled"].get<double>());
  EXPECT_LT(cheap["ripple_db"]["controlled"].get<double>(), cheap["ripple_db"]["model"].get<double>());
  EXPECT_LT(cheap["max_input_noise"].get<double>(), expensive["max_input_noise"].get<double>());
  // Filtering the lowest frequencies lets a larger program through (the thesis's table).
  const json band = expect_result(run("design lq --model " + quoted(model()) +
                                      " --R 1e-5 --R0 20 --bandpass 50,1200 --samples 20000 --out " + quoted(dir_ / "c.json")));
  EXPECT_GT(band["max_input_worst"].get<double>(), cheap["max_input_worst"].get<double>());
}

TEST_F(CliDesignModel, MaxInputSearchesTheFlattestWeightThatAllowsIt) {
  // The target lies between what cheap (R = 1e-8, the search's lower end) and expensive control allow.
  const std::string base = "design lq --model " + quoted(model()) + " --R0 20 --bandpass 20,1200 --samples 20000 ";
  const double cheap = expect_result(run(base + "--R 1e-8 --out " + quoted(dir_ / "a.json")))["max_input_noise"];
  const double expensive = expect_result(run(base + "--R 3 --out " + quoted(dir_ / "b.json")))["max_input_noise"];
  ASSERT_LT(cheap, expensive);
  const double target = 0.5 * (cheap + expensive);
  const fs::path out = dir_ / "ff.json";
  const json r = expect_result(run(base + "--max-input " + std::to_string(target) + " --out " + quoted(out)));
  const double sent = r["R_search"]["target_noise_amplitude"];  // the target as printed on the command line
  EXPECT_NEAR(sent, target, 1e-6);
  EXPECT_FALSE(r["R_search"]["at_lower_bound"].get<bool>());
  const double R = r["R"];
  EXPECT_GT(R, 1e-8);
  EXPECT_LT(R, 3.0);
  EXPECT_GE(r["max_input_noise"].get<double>(), sent);
  // Checked with the library directly: the file's controller allows the target, a design 2 % cheaper does not.
  const models::LqFeedforward ff = models::lq_feedforward_from_json(json::parse(text_of(out)));
  EXPECT_EQ(ff.weights.R, R);
  EXPECT_EQ(ff.meta["R_search"], r["R_search"]);
  const std::vector<dsp::Biquad> band = dsp::butterworth_bandpass(2, 20.0, 1200.0, 3000.0);
  EXPECT_GE(models::max_input(ff, band, 20000, 1).noise, sent);
  const models::LqFeedforward cheaper = models::design_lq(models::load_linear_model(model()), {R / 1.02, 20.0});
  EXPECT_LT(models::max_input(cheaper, band, 20000, 1).noise, sent);
  // The drive's peak gain: at least the gain at any other frequency, and at most ‖h‖₁ = 1/max_input_worst.
  const double peak_db = r["drive_peak"]["gain_db"];
  const dsp::SosFilter filter(band);
  for (const double f : {10.0, 20.0, 40.0, 150.0, 600.0, 1200.0}) {
    const double db = 20.0 * std::log10(std::abs(filter.response(f, 3000.0) * models::response(ff.controller(), f, 3000.0)));
    EXPECT_LE(db, peak_db + 1e-9) << f << " Hz";
  }
  EXPECT_LE(peak_db, -20.0 * std::log10(r["max_input_worst"].get<double>()) + 1e-9);
  // Where the controller's gain passes through 1: the file's controller has unit gain there.
  ASSERT_FALSE(r["unity_gain_hz"].empty());
  for (const double f : r["unity_gain_hz"]) {
    EXPECT_NEAR(std::abs(models::response(ff.controller(), f, 3000.0)), 1.0, 1e-6) << f << " Hz";
  }
  // --R and --max-input choose the weight two ways: one at a time; the target lies in (0, 1].
  RunResult both = run("design lq --model " + quoted(model()) + " --R 1 --max-input 0.3 --out " + quoted(dir_ / "x.json"));
  expect_usage_error(both);
  EXPECT_TRUE(contains(both.err, "--max-input")) << both.err;
  for (const char* bad : {"0", "1.5"}) {
    both = run("design lq --model " + quoted(model()) + " --max-input " + bad + " --out " + quoted(dir_ / "x.json"));
    expect_usage_error(both);
    EXPECT_TRUE(contains(both.err, "--max-input")) << both.err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "x.json"));
}

TEST_F(CliDesignModel, PlotsWritesThePoleZeroAndMagnitudeFigures) {
  const fs::path plots = dir_ / "plots";
  const json r = expect_result(run("design lq --model " + quoted(model()) + " --R 3 --R0 20 --samples 1000 --out " +
                                   quoted(dir_ / "ff.json") + " --plot " + quoted(plots)));
  for (const char* name : {"poles_zeros", "magnitude"}) {
    ASSERT_TRUE(r["plots"].contains(name)) << name;
    const fs::path image = r["plots"][name].get<std::string>();
    EXPECT_TRUE(fs::exists(image)) << image;
    EXPECT_GT(fs::file_size(image), 1000u) << image;
    EXPECT_TRUE(fs::exists(plots / (std::string(name) + ".gp"))) << name;
  }
}

TEST_F(CliDesignModel, BadWeightsAndBandPassAreRefusedNamingThem) {
  const std::string base = "design lq --model " + quoted(model()) + " --out " + quoted(dir_ / "ff.json");
  RunResult r = run(base + " --R 0");
  expect_usage_error(r);
  EXPECT_TRUE(contains(r.err, "--R")) << r.err;
  r = run(base + " --R -3");
  expect_usage_error(r);
  EXPECT_TRUE(contains(r.err, "--R")) << r.err;
  r = run(base + " --R0 -1");
  expect_usage_error(r);
  EXPECT_TRUE(contains(r.err, "--R0")) << r.err;
  for (const char* bad : {"1200", "1200,20", "a,b", "-5,100", "20,1200,3"}) {
    r = run(base + " --bandpass " + quoted(std::string(bad)));
    expect_usage_error(r);
    EXPECT_TRUE(contains(r.err, "--bandpass")) << bad << ": " << r.err;
  }
  // Above the model's Nyquist frequency (1500 Hz): known once the model is read, and still a bad option.
  r = run(base + " --bandpass 20,1600");
  expect_usage_error(r);
  EXPECT_TRUE(contains(r.err, "--bandpass")) << r.err;
  EXPECT_TRUE(contains(r.err, "Nyquist")) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "ff.json"));
}

TEST_F(CliDesignModel, TargetHighpassIsRecordedAndTheReportGivesEachLevel) {
  const fs::path out = dir_ / "ff.json";
  const json r = expect_result(run("design lq --model " + quoted(model()) +
                                   " --R 0.1 --R0 20 --bandpass 20,1200 --target-highpass 80,3 --samples 20000 --out " +
                                   quoted(out)));
  EXPECT_EQ(r["target"]["highpass_hz"], 80.0);
  EXPECT_EQ(r["target"]["order"], 3);
  EXPECT_NEAR(r["target"]["mid_hz"].get<double>(), std::sqrt(80.0 * 1200.0), 1e-9);
  const models::LqFeedforward ff = models::lq_feedforward_from_json(json::parse(text_of(out)));
  ASSERT_TRUE(ff.has_target());
  EXPECT_EQ(ff.target.band.highpass_hz, 80.0);
  EXPECT_EQ(ff.target.band.order, 3);
  // The safe amplitude is the noise limit of the file's controller; each level's drive and excursion
  // scale from it and from the excursion of a unit program, computed here from the file.
  const auto band = dsp::butterworth_bandpass(2, 20.0, 1200.0, 3000.0);
  const double safe = models::max_input(ff, band, 20000, 1).noise;
  const double unit_excursion = models::noise_excursion(ff, band, 20000, 1);
  EXPECT_NEAR(r["safe_amplitude"].get<double>(), safe, 1e-12 * safe);
  ASSERT_EQ(r["levels"].size(), 10u);
  for (const json& row : r["levels"]) {
    const double level = row["level"];
    EXPECT_NEAR(row["drive_peak"].get<double>(), level / safe, 1e-9 * level / safe);
    EXPECT_EQ(row["drive_within_limits"].get<bool>(), level / safe <= 1.0);
    EXPECT_NEAR(row["excursion_peak"].get<double>(), level * unit_excursion, 1e-9 * unit_excursion);
  }
  EXPECT_GT(unit_excursion, 0.0);
}

TEST_F(CliDesignModel, BadTargetHighpassIsRefusedNamingIt) {
  const std::string base = "design lq --model " + quoted(model()) + " --out " + quoted(dir_ / "ff.json");
  for (const char* bad : {"abc", "80,0", "80,9", "80,x"}) {
    const RunResult r = run(base + " --target-highpass " + quoted(std::string(bad)));
    expect_usage_error(r);
    EXPECT_TRUE(contains(r.err, "--target-highpass")) << bad << ": " << r.err;
  }
  for (const char* bad : {"0", "-10", "1300"}) {
    const RunResult r = run(base + " --bandpass 20,1200 --target-highpass " + quoted(std::string(bad)));
    expect_usage_error(r);
    EXPECT_TRUE(contains(r.err, "--target-highpass")) << bad << ": " << r.err;
  }
  expect_usage_error(run(base + " --max-input 0.3 --target-highpass 80"));
  EXPECT_FALSE(fs::exists(dir_ / "ff.json"));
}

TEST_F(CliDesignModel, AnSsModelIsDesignedOnByItsLinearization) {
  // An ss model started from the linear model with no training is that linear model exactly (its networks'
  // last layers zero): designing on it is designing on the linear model.
  const fs::path ss = dir_ / "ss.json";
  expect_result(run("identify ss --data " + quoted(dir_ / "run.csv") + " --fs 3000 --linear " + quoted(model()) +
                    " --hidden 3 --lags 4 --epochs 0 --out " + quoted(ss)));
  const std::string options = " --R 3 --R0 20 --bandpass 20,1200 --samples 4000 --out ";
  const json from_linear = expect_result(run("design lq --model " + quoted(model()) + options + quoted(dir_ / "a.json")));
  const json from_ss = expect_result(run("design lq --model " + quoted(ss) + options + quoted(dir_ / "b.json")));
  EXPECT_EQ(from_ss["order"], from_linear["order"]);
  for (const char* key : {"max_input_worst", "max_input_noise", "pole_radius"}) {
    const double expected = from_linear[key].get<double>();
    EXPECT_NEAR(from_ss[key].get<double>(), expected, 1e-6 * (1.0 + std::abs(expected))) << key;
  }
  EXPECT_NEAR(from_ss["ripple_db"]["controlled"].get<double>(), from_linear["ripple_db"]["controlled"].get<double>(), 1e-6);
  ASSERT_EQ(from_ss["L"].size(), from_linear["L"].size());
  for (std::size_t i = 0; i < from_linear["L"].size(); ++i) {
    EXPECT_NEAR(from_ss["L"][i].get<double>(), from_linear["L"][i].get<double>(), 1e-9) << "L[" << i << "]";
  }
}

TEST_F(CliDesign, MissingOrWrongModelIsRefusedNamingIt) {
  RunResult r = run("design lq --model " + quoted(dir_ / "nope.json") + " --out " + quoted(dir_ / "ff.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "nope.json")) << r.err;
  const fs::path narx = file("nn.json", "{\"format\": \"panelbass.model/1\", \"kind\": \"narx\"}");
  r = run("design lq --model " + quoted(narx) + " --out " + quoted(dir_ / "ff.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "nn.json")) << r.err;
  EXPECT_TRUE(contains(r.err, "kind")) << r.err;
  r = run("design lq --out " + quoted(dir_ / "ff.json"));
  expect_usage_error(r);
  EXPECT_TRUE(contains(r.err, "--model")) << r.err;
  r = run("design");
  expect_usage_error(r);
}

TEST_F(CliDesign, HelpShowsAnExample) {
  const RunResult r = run("design lq --help");
  EXPECT_EQ(r.status, 0);
  EXPECT_TRUE(contains(r.out, "Example")) << r.out;
  EXPECT_TRUE(contains(r.out, "--bandpass")) << r.out;
  EXPECT_TRUE(contains(r.out, "--target-highpass 80,2")) << r.out;
}

}  // namespace
}  // namespace panelbass

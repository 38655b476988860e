// The control pipeline run as a user runs it, on small records: the plant driven in its operating regime
// (`simulate --signal control`), `design nn`, `chain` and `evaluate`, and what each says about bad input.

#include <gtest/gtest.h>

#include <cmath>

#include "dsp/butterworth.h"
#include "dsp/csv_table.h"
#include "engine/chain_file.h"
#include "models/control/feedback_design.h"
#include "models/control/lq_feedforward.h"
#include "models/io/json_file.h"
#include "models/control/neural_feedback.h"
#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

using namespace testing_support;

// A failure by the CLI contract whose one-line message names `what`.
void expect_failure(const RunResult& r, const std::string& what) {
  testing_support::expect_failure(r);
  EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
}

class CliControl : public CliTest {
 protected:
  /// A linear model of the `linear` preset and the LQ feedforward controller on it.
  void SetUp() override {
    expect_result(run("simulate --plant linear --signal noise --samples 4000 --seed 3 --out " + quoted(dir_ / "run.csv")));
    expect_result(run("identify linear --data " + quoted(dir_ / "run.csv") +
                      " --fs 3000 --method oe --order 6 --out " + quoted(dir_ / "lin.json")));
    expect_result(run("design lq --model " + quoted(dir_ / "lin.json") + " --R 1e-3 --R0 20 --out " + quoted(path("ff.json"))));
  }
  fs::path path(const char* name) const { return dir_ / name; }
};

// `--program-share` reaches the record: the drive simulate writes is control_record's, computed here with the
// same options, and differs from the drive-level record of the same seed.
TEST_F(CliControl, ProgramShareShapesTheControlSignal) {
  expect_result(run("simulate --plant linear --signal control --ff " + quoted(path("ff.json")) +
                    " --samples 3000 --seed 5 --sine-peak 0.6 --program-share 1 --out " + quoted(path("prog.csv"))));
  expect_result(run("simulate --plant linear --signal control --ff " + quoted(path("ff.json")) +
                    " --samples 3000 --seed 5 --sine-peak 0.6 --out " + quoted(path("drive.csv"))));
  const Eigen::VectorXd prog = dsp::read_csv(path("prog.csv"), {"u"}).column("u");
  const Eigen::VectorXd drive = dsp::read_csv(path("drive.csv"), {"u"}).column("u");
  const models::LqFeedforward ff = models::lq_feedforward_from_json(models::read_json_file(path("ff.json")));
  models::FeedbackDesignOptions o;
  o.samples = 3000;
  o.sine_peak = 0.6;
  o.program_share = 1.0;
  const Eigen::VectorXd expected = models::control_record(ff, dsp::butterworth_band(2, 20.0, 1200.0, 3000.0), o, 5).u;
  ASSERT_EQ(prog.size(), expected.size());
  EXPECT_LT((prog - expected).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_GT((prog - drive).cwiseAbs().maxCoeff(), 1e-3);
  const RunResult bad = run("simulate --plant linear --signal control --ff " + quoted(path("ff.json")) +
                            " --samples 3000 --program-share 2 --out " + quoted(path("bad.csv")));
  expect_usage_error(bad);
  EXPECT_TRUE(contains(bad.err, "--program-share")) << bad.err;
}

TEST_F(CliControl, ControlSignalIsTheFeedforwardOutputAndTheWholeChainEvaluates) {
  const json sim = expect_result(run("simulate --plant linear --signal control --ff " + quoted(path("ff.json")) +
                                     " --samples 3000 --seed 5 --sine-peak 0.6 --out " + quoted(path("reg.csv"))));
  EXPECT_EQ(sim["signal"], "control");
  split_csv(path("reg.csv"), 2000);
  expect_result(run("identify narx --data " + quoted(path("est.csv")) + " --val " + quoted(path("val.csv")) +
                    " --fs 3000 --na 3 --nb 3 --hidden 4 --max-iter 5 --seed 1 --out " + quoted(path("narx.json"))));
  const json nn = expect_result(run("design nn --plant " + quoted(path("narx.json")) + " --ff " + quoted(path("ff.json")) +
                                    " --hidden 4 --iterations 3 --samples 2000 --out " + quoted(path("fb.json"))));
  EXPECT_LE(nn["jc_val_after_pct"].get<double>(), nn["jc_val_before_pct"].get<double>());
  const models::NeuralFeedback fb = models::neural_feedback_from_json(json::parse(text_of(path("fb.json"))));
  EXPECT_EQ(fb.structure.hidden, std::vector<int>{4});
  // the controller file says how its training records were made
  EXPECT_EQ(fb.meta.at("samples"), 2000);
  EXPECT_EQ(fb.meta.at("sine_peak"), models::FeedbackDesignOptions{}.sine_peak);
  EXPECT_EQ(fb.meta.at("restart_jc_val_pct"), nn["restart_jc_val_pct"]);
  EXPECT_EQ(fb.meta.at("desired"), "linear-model");
  EXPECT_EQ(fb.meta.at("dc_penalty"), 1.0);
  // the options beyond the thesis's reach the design and its file
  const json other = expect_result(run("design nn --plant " + quoted(path("narx.json")) + " --ff " + quoted(path("ff.json")) +
                                       " --hidden 4 --iterations 1 --samples 2000 --desired plant-small-signal"
                                       " --distortion-weighting --dc-penalty 0.5 --sine-band 50,300"
                                       " --restarts 2 --keep worst-probe --probes 80,160 --out " +
                                       quoted(path("fb2.json"))));
  const models::NeuralFeedback fb2 = models::neural_feedback_from_json(json::parse(text_of(path("fb2.json"))));
  EXPECT_EQ(fb2.meta.at("desired"), "plant-small-signal");
  EXPECT_EQ(fb2.meta.at("distortion_weighting"), true);
  EXPECT_EQ(fb2.meta.at("dc_penalty"), 0.5);
  EXPECT_EQ(fb2.meta.at("sine_band"), json({50.0, 300.0}));
  EXPECT_NE(other["jc_val_before_pct"], nn["jc_val_before_pct"]) << "another target, another J_c";
  EXPECT_EQ(fb2.meta.at("keep"), "worst-probe");
  EXPECT_EQ(fb2.meta.at("probe_hz"), json({80.0, 160.0}));
  EXPECT_EQ(fb2.meta.at("restart_probe_change_db"), other["restart_probe_change_db"]);
  // the restart kept by its worst probe: its THD changes on the plant model are those `evaluate` reports for
  // the model-mode chain (the model's THD with the feedback against without), at the same probes and peak
  const int kept = other["chosen_restart"].get<int>();
  const json kept_changes = other["restart_probe_change_db"].at(static_cast<std::size_t>(kept));
  expect_result(run("chain --bandpass 20,1200 --ff " + quoted(path("ff.json")) + " --fb " + quoted(path("fb2.json")) +
                    " --source model --out " + quoted(path("chain2.json"))));
  const json e2 = expect_result(run("evaluate --plant linear --chain " + quoted(path("chain2.json")) +
                                    " --noise-samples 8000 --probes 80,160 --probe-peak 0.6"));
  for (std::size_t p = 0; p < 2; ++p) {
    const double without = e2["rows"][1]["probes"][p]["model_thd_pct"].get<double>();
    const double with = e2["rows"][2]["probes"][p]["model_thd_pct"].get<double>();
    EXPECT_NEAR(20.0 * std::log10(with / without), kept_changes[p].get<double>(), 1e-6) << p;
  }
  // trained on from a controller file with no iteration: its weights; tuned on a device: named in the meta,
  // and refused for a target that is not each step's fundamental
  expect_result(run("design nn --plant " + quoted(path("narx.json")) + " --ff " + quoted(path("ff.json")) +
                    " --iterations 0 --samples 2000 --start-from " + quoted(path("fb2.json")) + " --out " +
                    quoted(path("fb3.json"))));
  const models::NeuralFeedback fb3 = models::neural_feedback_from_json(json::parse(text_of(path("fb3.json"))));
  EXPECT_EQ(fb3.net.parameters(), fb2.net.parameters());
  EXPECT_EQ(fb3.meta.at("start_from"), path("fb2.json").string());
  const std::string tuned = "design nn --plant " + quoted(path("narx.json")) + " --ff " + quoted(path("ff.json")) +
                            " --hidden 3 --iterations 1 --samples 2000 --tune-on linear --out " + quoted(path("fb4.json"));
  const RunResult untargeted = run(tuned);  // refused by the use case's check, as the design-nn job refuses it
  expect_usage_error(untargeted);
  EXPECT_TRUE(contains(untargeted.err, "--tune-on: tuning on the device")) << untargeted.err;
  EXPECT_TRUE(contains(untargeted.err, "plant-fundamental")) << untargeted.err;
  expect_result(run(tuned + " --desired plant-fundamental --tune-playbacks 2"));
  EXPECT_EQ(json::parse(text_of(path("fb4.json"))).at("meta").at("tuned_on"), "linear");
  EXPECT_EQ(json::parse(text_of(path("fb4.json"))).at("meta").at("device_playbacks"), 2);
  // playbacks without a device to play them on: refused as bad usage, named
  const RunResult playbacks_alone = run("design nn --plant " + quoted(path("narx.json")) + " --ff " +
                                        quoted(path("ff.json")) + " --tune-playbacks 2 --out " + quoted(path("fb5.json")));
  expect_usage_error(playbacks_alone);
  EXPECT_TRUE(contains(playbacks_alone.err, "--tune-on")) << playbacks_alone.err;
  const double worst_kept = std::max(kept_changes[0].get<double>(), kept_changes[1].get<double>());
  for (const json& changes : other["restart_probe_change_db"]) {
    EXPECT_LE(worst_kept, std::max(changes[0].get<double>(), changes[1].get<double>()));
  }

  const json chain = expect_result(run("chain --bandpass 20,1200 --ff " + quoted(path("ff.json")) + " --fb " +
                                       quoted(path("fb.json")) + " --source sensor --out " + quoted(path("chain.json"))));
  const engine::ChainConfig config = engine::load_chain_file(path("chain.json"));
  ASSERT_TRUE(config.feedback.has_value());
  EXPECT_EQ(config.feedback->source, engine::FeedbackSource::sensor);
  EXPECT_EQ(config.feedforward->path, "ff.json") << "model paths relative to the chain file";

  const json e = expect_result(run("evaluate --plant linear --chain " + quoted(path("chain.json")) +
                                   " --noise-samples 8000 --probes 80,160 --out " + quoted(path("eval.json")) +
                                   " --plot " + quoted(path("plots"))));
  ASSERT_EQ(e["rows"].size(), 3u);
  EXPECT_EQ(json::parse(text_of(path("eval.json"))), e);
  EXPECT_FALSE(e.contains("attribution")) << "only on request";
  for (const char* name : {"response", "harmonics"}) {
    const fs::path image = e["plots"][name].get<std::string>();
    EXPECT_GT(fs::file_size(image), 1000u) << image;
    EXPECT_TRUE(fs::exists(path("plots") / ("evaluation_" + std::string(name) + ".gp"))) << name;
  }
  const json& bare = e["rows"][0];
  const json& ff = e["rows"][1];
  EXPECT_LT(ff["ripple_db"].get<double>(), bare["ripple_db"].get<double>());
  const double noise_floor = e["jc_noise_floor_pct"].get<double>();
  for (const json& row : e["rows"]) {
    EXPECT_LE(row["max_drive"].get<double>(), 1.0);
    EXPECT_EQ(row["faults"], 0);
    // through the noisy sensor, the sensor's independent noise power adds to the transducer's own error
    const double clean = row["jc_pct"].get<double>();
    EXPECT_NEAR(row["measured_jc_pct"].get<double>(), clean + noise_floor, 0.1 * (clean + noise_floor)) << row["name"];
    ASSERT_EQ(row["probes"].size(), 2u);
    EXPECT_TRUE(std::isfinite(row["probes"][1]["thd_pct"].get<double>()));
    // the harmonics listed are those of the THD and of H2/H3: THD = sqrt(Σ 10^(dB/10)) · 100 %
    for (const json& probe : row["probes"]) {
      const json& h = probe["harmonics_db"];
      ASSERT_GE(h.size(), 2u);
      EXPECT_DOUBLE_EQ(h[0].get<double>(), probe["h2_db"].get<double>());
      EXPECT_DOUBLE_EQ(h[1].get<double>(), probe["h3_db"].get<double>());
      double power = 0.0;
      for (const json& db : h) power += db.is_null() ? 0.0 : std::pow(10.0, db.get<double>() / 10.0);
      EXPECT_NEAR(100.0 * std::sqrt(power), probe["thd_pct"].get<double>(), 1e-9 * (1.0 + probe["thd_pct"].get<double>()));
    }
  }
}

// Identification for control: `simulate --signal control --fb` drives the plant as the feedback controller does in
// model mode (the engine's sample-by-sample runner, computed here, gives the same drive), and `identify narx
// --start-from` trains on from the plant model (no iteration: the same weights and scaling; more: J_val no worse).
TEST_F(CliControl, ClosedLoopRecordsRefineThePlantModelFromWhereItIs) {
  expect_result(run("simulate --plant linear --signal control --ff " + quoted(path("ff.json")) +
                    " --samples 3000 --seed 5 --sine-peak 0.6 --out " + quoted(path("reg.csv"))));
  split_csv(path("reg.csv"), 2000);
  expect_result(run("identify narx --data " + quoted(path("est.csv")) + " --val " + quoted(path("val.csv")) +
                    " --fs 3000 --na 3 --nb 3 --hidden 4 --max-iter 5 --seed 1 --out " + quoted(path("narx.json"))));
  expect_result(run("design nn --plant " + quoted(path("narx.json")) + " --ff " + quoted(path("ff.json")) +
                    " --hidden 4 --iterations 3 --samples 2000 --out " + quoted(path("fb.json"))));
  const json loop = expect_result(run("simulate --plant linear --signal control --ff " + quoted(path("ff.json")) +
                                      " --fb " + quoted(path("fb.json")) + " --samples 3000 --seed 7 --sine-peak 0.6 --out " +
                                      quoted(path("loop.csv"))));
  EXPECT_EQ(loop["signal"], "control");
  const Eigen::VectorXd drive = dsp::read_csv(path("loop.csv"), {"u"}).column("u");
  const models::LqFeedforward ff = models::lq_feedforward_from_json(models::read_json_file(path("ff.json")));
  models::FeedbackDesignOptions o;
  o.samples = 3000;
  o.sine_peak = 0.6;
  const Eigen::VectorXd u_ff = models::control_record(ff, dsp::butterworth_band(2, 20.0, 1200.0, 3000.0), o, 7).u;
  const models::NeuralFeedback fb = models::neural_feedback_from_json(models::read_json_file(path("fb.json")));
  models::FeedbackRunner runner(fb);
  ASSERT_EQ(drive.size(), u_ff.size());
  double largest_change = 0.0;
  for (Eigen::Index k = 0; k < u_ff.size(); ++k) {
    const double v = runner.control(u_ff[k]);
    runner.push_output(runner.plant_model_output());
    ASSERT_NEAR(drive[k], v, 1e-9) << "sample " << k;
    largest_change = std::max(largest_change, std::abs(v - u_ff[k]));
  }
  EXPECT_GT(largest_change, 1e-4) << "the trained controller changes the feedforward's drive";
  EXPECT_LE(drive.cwiseAbs().maxCoeff(), 1.0);

  split_csv(path("loop.csv"), 2000);
  const std::string refine = "identify narx --data " + quoted(path("est.csv")) + " --val " + quoted(path("val.csv")) +
                             " --fs 3000 --train oem-d --start-from " + quoted(path("narx.json"));
  const json kept = expect_result(run(refine + " --max-iter 0 --out " + quoted(path("same.json"))));
  const json start = json::parse(text_of(path("narx.json"))), same = json::parse(text_of(path("same.json")));
  EXPECT_EQ(same["params"], start["params"]) << "structure and weights kept";
  EXPECT_EQ(same["scaling"], start["scaling"]) << "the start's scaling, not the new record's";
  EXPECT_EQ(same["meta"]["start_from"], path("narx.json").string());
  const json refined =
      expect_result(run(refine + " --max-iter 4 --out " + quoted(path("refined.json")) + " --history " + quoted(path("h.json"))));
  ASSERT_GE(json::parse(text_of(path("h.json")))["history"].size(), 2u);
  EXPECT_LT(refined["J_val_pct"].get<double>(), 1.01 * kept["J_val_pct"].get<double>())
      << "early stopping keeps the start unless training improves on it";

  // what a refinement cannot take, named
  expect_failure(run(refine + " --hidden 6 --out " + quoted(path("x.json"))), "--start-from");
  const RunResult seeded = run(refine + " --friction-units 3 --out " + quoted(path("x.json")));
  expect_usage_error(seeded);
  EXPECT_NE(seeded.err.find("--friction-units: cannot be combined with a start_from model"), std::string::npos) << seeded.err;
  expect_failure(run("identify narx --data " + quoted(path("est.csv")) + " --fs 3000 --start-from " +
                     quoted(dir_ / "lin.json") + " --out " + quoted(path("x.json"))),
                 "expected a NARX model");
  expect_failure(run("simulate --plant linear --signal noise --fb " + quoted(path("fb.json")) + " --samples 100 --out " +
                     quoted(path("x.csv"))),
                 "--fb needs --signal control");
}

TEST_F(CliControl, AttributeEvaluatesEachNonlinearTermAlone) {
  expect_result(run("chain --bandpass 20,1200 --ff " + quoted(path("ff.json")) + " --out " + quoted(path("chain.json"))));
  const RunResult r = run("evaluate --plant panel-exciter --chain " + quoted(path("chain.json")) +
                          " --noise-samples 4096 --probes 160 --probe-peak 0.6 --attribute");
  const json e = expect_result(r);
  // panel-exciter's terms that are on (its thermal compression is off), each with the chain's rows but the feedback
  const json& terms = e.at("attribution");
  const std::vector<std::string> expected{"stiffness", "force_factor", "inductance", "friction", "clipping"};
  ASSERT_EQ(terms.size(), expected.size());
  for (std::size_t t = 0; t < expected.size(); ++t) {
    EXPECT_EQ(terms[t]["term"], expected[t]);
    ASSERT_EQ(terms[t]["rows"].size(), 2u);
    EXPECT_EQ(terms[t]["rows"][1]["name"], e["rows"][1]["name"]);
    EXPECT_EQ(terms[t]["rows"][1]["probes"][0]["amplitude"], e["rows"][1]["probes"][0]["amplitude"]);
  }
  // behind band-pass + LQ at 160 Hz the friction makes most of the distortion (its odd force, and no even harmonic)
  const json& friction = terms[3]["rows"][1]["probes"][0];
  for (std::size_t t = 0; t < expected.size(); ++t) {
    if (t == 3) continue;
    EXPECT_LT(terms[t]["rows"][1]["probes"][0]["thd_pct"].get<double>(), friction["thd_pct"].get<double>()) << expected[t];
  }
  EXPECT_TRUE(contains(r.err, "which term makes the distortion")) << r.err;
  EXPECT_TRUE(contains(r.err, "friction")) << r.err;
}

// `design nn` takes a neural state-space plant model (identify ss) as it takes a NARX one: the controller file
// holds that model, read back by its kind, and the chain built on it runs (evaluate plays it through the
// engine's controller stage in model mode, its own ss plant model in the loop).
TEST_F(CliControl, DesignNnTakesAStateSpacePlantModelAndItsChainRuns) {
  expect_result(run("simulate --plant linear --signal control --ff " + quoted(path("ff.json")) +
                    " --samples 3000 --seed 5 --sine-peak 0.6 --out " + quoted(path("reg.csv"))));
  split_csv(path("reg.csv"), 2000);
  expect_result(run("identify ss --data " + quoted(path("est.csv")) + " --val " + quoted(path("val.csv")) +
                    " --fs 3000 --nx 2 --hidden 3 --lags 4 --window 40 --epochs 2 --seed 1 --out " + quoted(path("ss.json"))));
  const json nn = expect_result(run("design nn --plant " + quoted(path("ss.json")) + " --ff " + quoted(path("ff.json")) +
                                    " --hidden 3 --iterations 3 --samples 2000 --out " + quoted(path("fb_ss.json"))));
  EXPECT_LE(nn["jc_val_after_pct"].get<double>(), nn["jc_val_before_pct"].get<double>());
  const json file = json::parse(text_of(path("fb_ss.json")));
  EXPECT_EQ(file["meta"]["plant_kind"], "ss");
  EXPECT_EQ(file["plant"]["params"]["theta"], json::parse(text_of(path("ss.json")))["params"]["theta"]);
  const models::NeuralFeedback fb = models::neural_feedback_from_json(file);
  EXPECT_TRUE(std::holds_alternative<models::SsModel>(fb.plant.model));
  expect_result(run("chain --bandpass 20,1200 --ff " + quoted(path("ff.json")) + " --fb " + quoted(path("fb_ss.json")) +
                    " --source model --out " + quoted(path("chain_ss.json"))));
  const json e = expect_result(run("evaluate --plant linear --chain " + quoted(path("chain_ss.json")) +
                                   " --noise-samples 8000 --probes 80 --probe-peak 0.6"));
  ASSERT_EQ(e["rows"].size(), 3u);
  EXPECT_TRUE(std::isfinite(e["rows"][2]["jc_pct"].get<double>())) << e["rows"][2].dump();
  // the model's THD through the loop: the controller's own ss plant model run with it
  const double with = e["rows"][2]["probes"][0]["model_thd_pct"].get<double>();
  const double without = e["rows"][1]["probes"][0]["model_thd_pct"].get<double>();
  EXPECT_TRUE(std::isfinite(with) && std::isfinite(without));
  EXPECT_NE(with, without) << "the controller acts in the loop";
}

TEST_F(CliControl, BadInputIsNamed) {
  // a chain without an LQ feedforward cannot be evaluated: J_c has no reference
  expect_result(run("chain --bandpass 20,1200 --out " + quoted(path("bp.json"))));
  RunResult r = run("evaluate --plant linear --chain " + quoted(path("bp.json")));
  expect_failure(r, "lq_feedforward");
  // a controller file that is not there, named with its path
  r = run("chain --ff " + quoted(path("missing.json")) + " --out " + quoted(path("c.json")));
  expect_failure(r, "missing.json");
  // design nn wants a NARX plant model, not a linear one
  r = run("design nn --plant " + quoted(dir_ / "lin.json") + " --ff " + quoted(path("ff.json")) + " --out " +
          quoted(path("fb.json")));
  expect_failure(r, "NARX");
  // --signal control without the controller is refused
  r = run("simulate --plant linear --signal control --samples 100 --out " + quoted(path("x.csv")));
  expect_failure(r, "--ff");
  // a bad band-pass is a usage error
  EXPECT_EQ(run("chain --bandpass 1200,20 --out " + quoted(path("c.json"))).status, 2);
  // and so are a bad sine band, an unknown target, two weightings at once, an unknown restart choice and a
  // negative probe, each named
  const std::string design = "design nn --plant " + quoted(path("narx.json")) + " --ff " + quoted(path("ff.json")) +
                             " --out " + quoted(path("fb.json"));
  for (const auto& [option, named] : std::vector<std::pair<std::string, std::string>>{
           {" --sine-band 400,30", "--sine-band"},
           {" --desired flat", "--desired"},
           {" --level-weighting --distortion-weighting", "--distortion-weighting"},
           {" --keep best", "--keep"},
           {" --probes 40,-80", "--probes"},
           {" --start-from fb.json --hidden 4", "--start-from"}}) {
    r = run(design + option);
    EXPECT_EQ(r.status, 2) << option;
    EXPECT_TRUE(contains(r.err, named)) << option << ": " << r.err;
  }
}

}  // namespace
}  // namespace panelbass

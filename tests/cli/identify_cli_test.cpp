// `panelbass identify linear|narx` and `panelbass validate` run as a user runs them.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>

#include "dsp/csv_table.h"
#include "dsp/record.h"
#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

using namespace testing_support;
using CliIdentify = CliTest;

/// 6000 samples of the panel exciter: rows 0..4000 to estimate, the rest to validate.
using CliIdentifyData = CliExciterSplitTest;

TEST_F(CliIdentifyData, LinearPrintsTheContractAndValidateAgrees) {
  const fs::path model = dir_ / "lin.json";
  const json r = expect_result(run("identify linear --data " + est() + " --val " + val() +
                                   " --fs 3000 --method oe --order 8 --out " + quoted(model)));
  for (const char* key : {"method", "order", "J_est_pct", "J_val_pct", "delay", "poles"}) EXPECT_TRUE(r.contains(key)) << key;
  EXPECT_EQ(r["method"], "oe");
  EXPECT_EQ(r["order"], 8);
  EXPECT_EQ(r["delay"], 2);
  EXPECT_EQ(r["poles"].size(), 8u);
  for (const auto& p : r["poles"]) EXPECT_LT(std::hypot(p[0].get<double>(), p[1].get<double>()), 1.0);
  // validate with the same protocol (50 outputs set the state) reproduces J_val.
  const json v = expect_result(run("validate --model " + quoted(model) + " --data " + val() + " --init 50"));
  EXPECT_NEAR(v["J_sim_pct"].get<double>(), r["J_val_pct"].get<double>(), 1e-9);
  EXPECT_EQ(v["kind"], "linear");
  // An OE model's A(q) is no predictor: its series-parallel J need not beat its simulation J; it is
  // reported, finite and positive, and when it is worse the output says why.
  EXPECT_GT(v["J_pred_pct"].get<double>(), 0.0);
  if (v["J_pred_pct"].get<double>() > v["J_sim_pct"].get<double>()) {
    EXPECT_TRUE(contains(v["J_pred_note"].get<std::string>(), "no noise model")) << v;
  } else {
    EXPECT_TRUE(v["J_pred_note"].is_null()) << v;
  }
  EXPECT_EQ(r["nk_source"].get<std::string>().rfind("estimated from the impulse response's first significant tap (lag 2", 0), 0u)
      << r["nk_source"];
}

// --sim-out writes the record validate judged: the data's own u and y beside the free run and the one-step
// prediction, so J_sim, J_pred and the RMSE computed here from its columns ([2A]) are the ones printed.
TEST_F(CliIdentifyData, ValidateSimOutWritesTheRecordItJudged) {
  const fs::path model = dir_ / "lin.json", sim = dir_ / "sim.csv";
  expect_result(run("identify linear --data " + est() + " --fs 3000 --method oe --order 4 --out " + quoted(model)));
  const json v = expect_result(
      run("validate --model " + quoted(model) + " --data " + val() + " --fs 3000 --init 50 --sim-out " + quoted(sim)));
  EXPECT_EQ(v["sim_out"], sim.string());
  const dsp::Record data = dsp::read_csv(dir_ / "val.csv", {"u", "y"});
  const dsp::Record out = dsp::read_csv(sim, {"u", "y", "y_sim", "y_pred"});
  ASSERT_EQ(out.samples(), data.samples());
  EXPECT_LT((out.column("u") - data.column("u")).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((out.column("y") - data.column("y")).cwiseAbs().maxCoeff(), 1e-9);
  const Eigen::Index init = 50, n = static_cast<Eigen::Index>(out.samples()) - init;
  const Eigen::VectorXd y = out.column("y").tail(n);
  const auto j_of = [&](const char* name) {
    return 100.0 * (out.column(name).tail(n) - y).squaredNorm() / y.squaredNorm();
  };
  EXPECT_NEAR(j_of("y_sim"), v["J_sim_pct"].get<double>(), 1e-6 * v["J_sim_pct"].get<double>());
  EXPECT_NEAR(j_of("y_pred"), v["J_pred_pct"].get<double>(), 1e-6 * v["J_pred_pct"].get<double>());
  const double rmse = std::sqrt((out.column("y_sim").tail(n) - y).squaredNorm() / static_cast<double>(n));
  EXPECT_NEAR(rmse, v["rmse"].get<double>(), 1e-6 * v["rmse"].get<double>());
  // a folder that is not there is refused before the work, naming the path
  const RunResult bad = run("validate --model " + quoted(model) + " --data " + val() + " --fs 3000 --sim-out " +
                            quoted(dir_ / "no-such-dir" / "s.csv"));
  expect_failure(bad);
  EXPECT_TRUE(contains(bad.err, "no-such-dir")) << bad.err;
}

// The bar on stderr (a line per tenth when stderr is a file) never goes back: an order scan then the final fit
// once ran 90 % → 0 % → 100 %.
TEST_F(CliIdentifyData, LinearProgressNeverGoesBack) {
  const RunResult out = run("identify linear --data " + est() + " --val " + val() +
                            " --fs 3000 --method arx --scan 1:4 --out " + quoted(dir_ / "p.json"));
  expect_result(out);
  int last = -1, lines = 0;
  std::istringstream err(out.err);
  for (std::string line; std::getline(err, line);) {
    const std::string tag = "identify arx: ";
    if (line.rfind(tag, 0) != 0 || line.back() != '%') continue;
    const int percent = std::stoi(line.substr(tag.size()));
    EXPECT_GE(percent, last) << out.err;
    last = percent;
    ++lines;
  }
  EXPECT_GE(lines, 2) << out.err;
  EXPECT_EQ(last, 100);
}

TEST_F(CliIdentifyData, LinearScanReportsEveryOrderAndTheRule) {
  const json r = expect_result(run("identify linear --data " + est() + " --val " + val() +
                                   " --fs 3000 --method zhu --scan 1:6 --out " + quoted(dir_ / "m.json")));
  ASSERT_EQ(r["scan"].size(), 6u);
  EXPECT_TRUE(r["order_rule"].get<std::string>().find("within 5 %") != std::string::npos);
  double best = 1e9;
  for (const auto& e : r["scan"]) best = std::min(best, e["J_val_pct"].get<double>());
  EXPECT_LE(r["J_val_pct"].get<double>(), 1.05 * best + 1e-9);
}

TEST_F(CliIdentifyData, LinearScanSkipsOrdersNoiseFreeDataCannotSupport) {
  // The linear preset without sensor noise: its response has fewer degrees of freedom than ARX(12, 12)
  // has parameters, so the top of a 1:12 scan cannot be fitted; the scan reports those orders and goes on.
  json plant = expect_result(run("plant show linear"));
  plant["sensor"]["noise_rms_V"] = 0.0;
  const fs::path quiet = file("quiet.json", plant.dump());
  expect_result(run("simulate --plant " + quoted(quiet) + " --samples 6000 --seed 5 --out " + quoted(dir_ / "all.csv")));
  split_csv(dir_ / "all.csv", 4000);
  const RunResult out = run("identify linear --data " + est() + " --val " + val() +
                            " --fs 3000 --method arx --scan 1:16 --out " + quoted(dir_ / "m.json"));
  const json r = expect_result(out);
  ASSERT_FALSE(r["scan_skipped"].empty());
  EXPECT_EQ(r["scan"].size() + r["scan_skipped"].size(), 16u);
  for (const auto& why : r["scan_skipped"]) {
    EXPECT_TRUE(contains(out.err, "scan skipped " + why.get<std::string>())) << out.err;
  }
  // Each skipped order is above every fitted one (they fail for having too many parameters).
  const std::string first = r["scan_skipped"][0];
  const int first_skipped = std::stoi(first.substr(first.find(' ') + 1));
  EXPECT_EQ(first_skipped, r["scan"].back()["order"].get<int>() + 1) << first;
  EXPECT_LT(r["J_val_pct"].get<double>(), 0.1);  // noise-free: far below the ~5 % of the noisy preset
}

TEST_F(CliIdentifyData, NarxTrainsAndValidateReadsItsModel) {
  const fs::path model = dir_ / "nn.json";
  const fs::path log = dir_ / "history.json";
  const RunResult out = run("identify narx --data " + est() + " --val " + val() +
                            " --fs 3000 --na 4 --nb 4 --hidden 5 --train pem,oem-d --max-iter 3 --seed 2 --out " +
                            quoted(model) + " --history " + quoted(log));
  const json r = expect_result(out);
  for (const char* key : {"J_est_pct", "J_val_pct", "iterations", "seconds", "params", "nk", "nk_source"}) {
    EXPECT_TRUE(r.contains(key)) << key;
  }
  EXPECT_FALSE(r.contains("history")) << "the training log is no part of the result on stdout";
  EXPECT_EQ(r["nk_source"], "given") << "--nk 0, the default";
  EXPECT_EQ(r["params"], 9 * 5 + 5 + 5 + 1);
  const json h = json::parse(text_of(log));
  EXPECT_GE(h["history"].size(), 2u);
  EXPECT_EQ(h["history"][0]["iter"], 0);
  // without --history the log goes to stderr, a line per iteration
  const RunResult plain = run("identify narx --data " + est() + " --fs 3000 --na 2 --nb 2 --hidden 2 --max-iter 1 --nk 2 --out " +
                              quoted(dir_ / "nn2.json"));
  EXPECT_EQ(expect_result(plain)["nk_source"], "given");
  EXPECT_TRUE(contains(plain.err, "identify narx: pem iteration 0: J_est")) << plain.err;
  EXPECT_FALSE(contains(plain.out, "pem iteration")) << plain.out;
  const json v = expect_result(run("validate --model " + quoted(model) + " --data " + val() + " --init 50"));
  EXPECT_EQ(v["kind"], "narx");
  EXPECT_NEAR(v["J_sim_pct"].get<double>(), r["J_val_pct"].get<double>(), 1e-9);
}

TEST_F(CliIdentifyData, NarxRestartsKeepTheLowestValidationJ) {
  // --restarts 3: three trainings from seeds 4, 5, 6; the model kept is the one of the lowest J_val, which is
  // the J_val printed, validate's J for the file, and the single-seed run of the chosen seed's.
  const fs::path model = dir_ / "restarts.json";
  const std::string common = "identify narx --data " + est() + " --val " + val() +
                             " --fs 3000 --na 3 --nb 3 --hidden 4 --max-iter 4 ";
  const json r = expect_result(run(common + "--seed 4 --restarts 3 --out " + quoted(model)));
  const json& tried = r["structure"]["restarts"]["tried"];
  ASSERT_EQ(tried.size(), 3u) << r;
  double lowest = 1e300;
  std::uint64_t lowest_seed = 0;
  for (const auto& t : tried) {
    if (t["J_val_pct"].get<double>() < lowest) {
      lowest = t["J_val_pct"].get<double>();
      lowest_seed = t["seed"].get<std::uint64_t>();
    }
  }
  EXPECT_EQ(r["structure"]["restarts"]["chosen_seed"].get<std::uint64_t>(), lowest_seed);
  EXPECT_EQ(tried[0]["seed"], 4);
  EXPECT_EQ(tried[2]["seed"], 6);
  EXPECT_NEAR(r["J_val_pct"].get<double>(), lowest, 1e-12 * lowest);
  const json v = expect_result(run("validate --model " + quoted(model) + " --data " + val() + " --init 50"));
  EXPECT_NEAR(v["J_sim_pct"].get<double>(), lowest, 1e-9 * lowest);
  const json single = expect_result(
      run(common + "--seed " + std::to_string(lowest_seed) + " --out " + quoted(dir_ / "single.json")));
  EXPECT_NEAR(single["J_val_pct"].get<double>(), lowest, 1e-9 * lowest);
  // without --val there is nothing to choose by: bad usage, refused before anything is trained
  expect_usage_error(run("identify narx --data " + est() + " --fs 3000 --na 2 --nb 2 --hidden 2 --restarts 2 --out " +
                     quoted(dir_ / "no.json")));
}

TEST_F(CliIdentifyData, NarxMultipleShootingStageTrainsAndBadOptionsAreNamed) {
  // --train pem,oem-ms,oem-d: the history names the stage; its model is judged by validate's J as any other
  const fs::path model = dir_ / "ms.json", log = dir_ / "ms-history.json";
  const std::string common = "identify narx --data " + est() + " --val " + val() +
                             " --fs 3000 --na 3 --nb 3 --hidden 4 --max-iter 3 --seed 2 ";
  const json r = expect_result(run(common + "--train pem,oem-ms,oem-d --ms-window 200 --ms-penalty 2 " +
                                   "--ms-penalty-growth 1.5 --ms-penalty-max 100 --out " + quoted(model) +
                                   " --history " + quoted(log)));
  const json h = json::parse(text_of(log));
  bool shooting = false;
  for (const auto& row : h["history"]) shooting |= row["mode"] == "oem-ms";
  EXPECT_TRUE(shooting) << h;
  const json v = expect_result(run("validate --model " + quoted(model) + " --data " + val() + " --init 50"));
  EXPECT_NEAR(v["J_sim_pct"].get<double>(), r["J_val_pct"].get<double>(), 1e-9);
  // a window shorter than na: the library's error, naming the option and the bound
  RunResult bad = run(common + "--train pem,oem-ms --ms-window 2 --out " + quoted(dir_ / "bad.json"));
  expect_failure(bad);
  EXPECT_TRUE(contains(bad.err, "multiple-shooting window must be ≥ max(na, 1) = 3 samples, got 2")) << bad.err;
  // oem-ms with another optimiser
  bad = run(common + "--train oem-ms --optimizer sd --out " + quoted(dir_ / "bad.json"));
  expect_failure(bad);
  EXPECT_TRUE(contains(bad.err, "oem-ms (multiple shooting) needs --optimizer lm")) << bad.err;
  // a multiple-shooting option without the stage
  bad = run(common + "--train pem,oem-d --ms-window 100 --out " + quoted(dir_ / "bad.json"));
  expect_failure(bad);
  EXPECT_TRUE(contains(bad.err, "--ms-window applies to the oem-ms stage")) << bad.err;
  // a penalty that is no positive number: a usage error naming the flag
  bad = run(common + "--train pem,oem-ms --ms-penalty -1 --out " + quoted(dir_ / "bad.json"));
  expect_usage_error(bad);
  EXPECT_TRUE(contains(bad.err, "--ms-penalty")) << bad.err;
  EXPECT_FALSE(fs::exists(dir_ / "bad.json"));
}

TEST_F(CliIdentifyData, NarxWeightColumnWeighsTheLoss) {
  // the estimation data with a weight column w: constant (no change: the loss divides by Σ w), zero on the
  // second half (another model), negative at one sample (an error naming it)
  const dsp::Record est_data = dsp::read_csv(dir_ / "est.csv", {"u", "y"});
  const auto with_weights = [&](const std::string& name, const Eigen::VectorXd& w) {
    dsp::Record r = est_data;
    r.add("w", w);
    dsp::write_csv(dir_ / name, r);
    return quoted(dir_ / name);
  };
  const Eigen::Index n = static_cast<Eigen::Index>(est_data.samples());
  Eigen::VectorXd half = Eigen::VectorXd::Ones(n);
  half.tail(n / 2).setZero();
  Eigen::VectorXd negative = Eigen::VectorXd::Ones(n);
  negative[100] = -1.0;
  // without weight decay (nor its re-estimation): its term D/(2·Σw)·|θ|² is scaled by the weights' total, the loss's
  // normaliser
  const std::string train =
      " --fs 3000 --na 3 --nb 3 --hidden 4 --train pem,oem-d --weight-decay 0 --evidence-decay off --max-iter 3 --seed 2 --out ";
  const json plain = expect_result(run("identify narx --data " + est() + train + quoted(dir_ / "a.json")));
  const json constant = expect_result(run("identify narx --data " + with_weights("c.csv", Eigen::VectorXd::Constant(n, 2.5)) +
                                          " --weight-col w" + train + quoted(dir_ / "b.json")));
  const json halved = expect_result(run("identify narx --data " + with_weights("h.csv", half) + " --weight-col w" + train +
                                        quoted(dir_ / "c.json")));
  EXPECT_NEAR(constant["J_est_pct"].get<double>(), plain["J_est_pct"].get<double>(), 1e-9 * plain["J_est_pct"].get<double>());
  EXPECT_GT(std::abs(halved["J_est_pct"].get<double>() - plain["J_est_pct"].get<double>()), 1e-6);
  RunResult r = run("identify narx --data " + with_weights("n.csv", negative) + " --weight-col w" + train +
                    quoted(dir_ / "d.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "weight at sample 100")) << r.err;
  r = run("identify narx --data " + est() + " --weight-col nope" + train + quoted(dir_ / "e.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "nope") && contains(r.err, "est.csv")) << r.err;
  // the validation file needs the column too
  r = run("identify narx --data " + with_weights("v.csv", half) + " --val " + val() + " --weight-col w" + train +
          quoted(dir_ / "f.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "val.csv")) << r.err;
}

TEST_F(CliIdentifyData, NarxFrictionUnitsAreSeededAndReported) {
  const std::string train = " --fs 3000 --na 3 --nb 3 --hidden 4 --train pem --max-iter 0 --seed 2 --out ";
  const json plain = expect_result(run("identify narx --data " + est() + train + quoted(dir_ / "a.json")));
  const json seeded = expect_result(run("identify narx --data " + est() + " --friction-units 2,6" + train + quoted(dir_ / "b.json")));
  // with no training the seeded nodes are the whole difference: nodes 0 and 1 in ratio 1 : 3, the rest as seeded by --seed
  const json a = json::parse(text_of(dir_ / "a.json")), b = json::parse(text_of(dir_ / "b.json"));
  const auto& ta = a["params"]["theta"];
  const auto& tb = b["params"]["theta"];
  const int inputs = 3 + 3 + 1;
  for (int i = 0; i < inputs; ++i) EXPECT_NEAR(tb[inputs + i].get<double>(), 3.0 * tb[i].get<double>(), 1e-12);
  for (std::size_t i = 2 * inputs; i < 4 * inputs; ++i) EXPECT_EQ(ta[i], tb[i]);
  EXPECT_EQ(seeded["structure"]["friction_units"]["gains"], json::array({2.0, 6.0}));
  EXPECT_GT(seeded["structure"]["friction_units"]["velocity_fit_r2"].get<double>(), 0.5);
  EXPECT_EQ(b["meta"]["friction_units"], seeded["structure"]["friction_units"]);
  EXPECT_FALSE(plain["structure"].contains("friction_units"));
  // refused as usage errors naming the flag, in the words the identify-narx job uses (usecases/identify_narx.h)
  RunResult r = run("identify narx --data " + est() + " --friction-units 1,2,3,4,5" + train + quoted(dir_ / "c.json"));
  expect_usage_error(r);
  EXPECT_TRUE(contains(r.err, "--friction-units: 5 gains x 1 lags need as many first-layer nodes, hidden[0] is 4")) << r.err;
  r = run("identify narx --data " + est() + " --friction-units 2 --grow 3" + train + quoted(dir_ / "d.json"));
  expect_usage_error(r);
  EXPECT_TRUE(contains(r.err, "cannot be combined with grow")) << r.err;
}

TEST_F(CliIdentifyData, GradientCheckShowsDynamicMatchesFiniteDifference) {
  const json r = expect_result(run("identify narx --data " + est() + " --fs 3000 --na 2 --nb 2 --hidden 3 "
                                   "--max-iter 5 --gradient-check --parameter 1"));
  const double dynamic = r["dynamic"], numeric = r["finite_difference"];
  EXPECT_NEAR(dynamic, numeric, 1e-4 * std::abs(numeric) + 1e-12);
  EXPECT_TRUE(r.contains("static"));
}

TEST_F(CliIdentify, BadInputFailsNamingTheProblem) {
  const fs::path csv = file("tiny.csv", "u,y\n0.1,0.2\n0.3,0.1\n");
  RunResult r = run("identify linear --data " + quoted(csv) + " --fs 3000 --out " + quoted(dir_ / "m.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "tiny.csv")) << r.err;
  const fs::path data = file("d.csv", "u,y\n1,2\n");
  r = run("identify linear --data " + quoted(data) + " --out " + quoted(dir_ / "m.json") + " --method nope");
  expect_usage_error(r);
  const fs::path broken = file("broken.json", "{\"format\": \"panelbass.model/1\", \"kind\": \"linear\"}");
  r = run("validate --model " + quoted(broken) + " --data " + quoted(data) + " --fs 3000");
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "broken.json")) << r.err;
  const fs::path unknown = file("unknown.json", "{\"format\": \"panelbass.model/1\", \"kind\": \"wavelet\"}");
  r = run("validate --model " + quoted(unknown) + " --data " + quoted(data) + " --fs 3000");
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "wavelet")) << r.err;
}

TEST_F(CliIdentify, CsvWithoutSampleRateAsksForFs) {
  std::string text = "u,y\n";
  for (int k = 0; k < 200; ++k) text += std::to_string(std::sin(k * 0.7)) + "," + std::to_string(std::cos(k * 0.3)) + "\n";
  const fs::path csv = file("d.csv", text);
  const RunResult r = run("identify linear --data " + quoted(csv) + " --out " + quoted(dir_ / "m.json"));
  expect_failure(r);
  EXPECT_TRUE(contains(r.err, "--fs")) << r.err;
}

}  // namespace
}  // namespace panelbass

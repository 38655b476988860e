// `panelbass identify ss` run as a user runs it: the model file it writes is read by validate (the J it
// reports is the J it selected on) and analyze; a training whose every candidate runs away in free run
// writes nothing and says why; bad options fail naming the problem.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/support/cli_runner.h"

namespace panelbass {
namespace {

using namespace testing_support;

/// 6000 samples of the panel exciter: rows 0..4000 to estimate, the rest to validate.
class CliIdentifySs : public CliExciterSplitTest {
 protected:
  /// Trains `identify ss OPTIONS` on the split into `model`, expects validate's J of the file to be the J_val
  /// it reported (the J it selected on), and returns the file's params.
  json trained_params(const std::string& options, const fs::path& model) {
    const json r = expect_result(run("identify ss --data " + est() + " --val " + val() + " --fs 3000 " + options +
                                     " --out " + quoted(model)));
    const json v = expect_result(run("validate --model " + quoted(model) + " --data " + val() + " --init 50"));
    EXPECT_NEAR(v["J_sim_pct"].get<double>(), r["J_val_pct"].get<double>(), 1e-9);
    return json::parse(text_of(model))["params"];
  }
};

TEST_F(CliIdentifySs, TrainsAndValidateAndAnalyzeReadItsModel) {
  const fs::path model = dir_ / "ss.json", log = dir_ / "h.json";
  const json r = expect_result(run("identify ss --data " + est() + " --val " + val() +
                                   " --fs 3000 --nx 4 --hidden 6 --lags 8 --window 40 --epochs 3 --seed 2 --out " +
                                   quoted(model) + " --history-out " + quoted(log)));
  for (const char* key : {"J_est_pct", "J_val_pct", "start_J_pct", "states", "params", "epochs", "best_epoch", "seconds"}) {
    EXPECT_TRUE(r.contains(key)) << key;
  }
  EXPECT_EQ(r["epochs"], 3);
  EXPECT_LE(r["J_val_pct"].get<double>(), r["start_J_pct"].get<double>()) << "the start is a candidate";
  EXPECT_EQ(json::parse(text_of(log))["history"].size(), 4u);
  const json v = expect_result(run("validate --model " + quoted(model) + " --data " + val() + " --init 50"));
  EXPECT_EQ(v["kind"], "ss");
  EXPECT_NEAR(v["J_sim_pct"].get<double>(), r["J_val_pct"].get<double>(), 1e-9);
  const json a = expect_result(run("analyze --model " + quoted(model) + " --data " + val() + " --out " +
                                   quoted(dir_ / "a.json")));
  EXPECT_EQ(a["kind"], "ss");
  // diagnose takes it as its baseline: the baseline's J is the one validate computes for the model.
  const json d = expect_result(run("diagnose --data " + est() + " --val " + val() + " --fs 3000 --model " +
                                   quoted(model) + " --max-findings 1 --out " + quoted(dir_ / "d.json")));
  const json baseline = json::parse(text_of(dir_ / "d.json"))["baseline"];
  EXPECT_EQ(baseline["kind"], "ss");
  EXPECT_NEAR(baseline["J_val_pct"].get<double>(), v["J_sim_pct"].get<double>(), 1e-9);
}

TEST_F(CliIdentifySs, WienerHammersteinStartIsWrittenAsAnSsModelThatValidateReads) {
  const fs::path model = dir_ / "wh.json";
  const json r = expect_result(run("identify ss --data " + est() + " --val " + val() +
                                   " --fs 3000 --nx 4 --hidden 4 --lags 8 --wiener-hammerstein --wh-iter 4 "
                                   "--wh-candidates 2 --epochs 0 --seed 3 --out " + quoted(model)));
  EXPECT_EQ(r["epochs"], 0);
  const json meta = json::parse(text_of(model))["meta"];
  const json start = meta["wiener_hammerstein_start"];
  for (const char* key : {"splits", "front_poles", "front_zeros", "front_states", "search_J_from_rest_pct", "J_from_rest_pct",
                          "iterations", "candidates", "linear_J_from_rest_pct"}) {
    EXPECT_TRUE(start.contains(key)) << key;
  }
  EXPECT_EQ(start["candidates"], 2);
  EXPECT_LE(start["iterations"].get<int>(), 4);
  EXPECT_GE(start["splits"].get<int>(), 2);
  EXPECT_LE(start["front_states"].get<int>(), r["states"].get<int>());
  EXPECT_LE(start["J_from_rest_pct"].get<double>(), start["linear_J_from_rest_pct"].get<double>());
  // validate's J of the file is the J it reports (selected on), the state from 50 measured samples.
  const json v = expect_result(run("validate --model " + quoted(model) + " --data " + val() + " --init 50"));
  EXPECT_EQ(v["kind"], "ss");
  EXPECT_NEAR(v["J_sim_pct"].get<double>(), r["J_val_pct"].get<double>(), 1e-9);
  const RunResult no_nodes = run("identify ss --data " + est() + " --fs 3000 --nx 4 --hidden 0 --lags 8 "
                                 "--wiener-hammerstein --epochs 0 --out " + quoted(dir_ / "bad.json"));
  expect_usage_error(no_nodes);
  EXPECT_TRUE(contains(no_nodes.err, "--wiener-hammerstein") && contains(no_nodes.err, "hidden")) << no_nodes.err;
}

TEST_F(CliIdentifySs, AverageOfModelsIsAnSsModelWhoseJIsTheMeanRunsAndWhoseMembersLowerIt) {
  // Three small models of the same split, two seeds and a worse one (no epochs: the linear start).
  const fs::path a = dir_ / "a.json", b = dir_ / "b.json", lin = dir_ / "lin.json", avg = dir_ / "avg.json";
  trained_params("--nx 4 --hidden 6 --lags 8 --window 40 --epochs 3 --seed 2", a);
  trained_params("--nx 4 --hidden 6 --lags 8 --window 40 --epochs 3 --seed 5", b);
  trained_params("--nx 2 --hidden 2 --lags 8 --window 40 --epochs 0 --seed 1", lin);
  const json r = expect_result(run("identify average --models " + quoted(a) + " " + quoted(b) + " " + quoted(lin) +
                                   " --val " + val() + " --fs 3000 --out " + quoted(avg)));
  // the J it reports is validate's J of the written file, and no higher than its best member's
  const json v = expect_result(run("validate --model " + quoted(avg) + " --data " + val() + " --init 50"));
  EXPECT_EQ(v["kind"], "ss");
  EXPECT_NEAR(v["J_sim_pct"].get<double>(), r["J_val_pct"].get<double>(), 1e-9);
  double best = 1e300;
  for (const json& c : r["candidates"]) best = std::min(best, c["J_val_pct"].get<double>());
  EXPECT_LE(r["J_val_pct"].get<double>(), best);
  // its states are its members' side by side
  auto states_of = [&](const json& files) {
    int sum = 0;
    for (const json& f : files) sum += json::parse(text_of(f.get<std::string>()))["params"]["states"].get<int>();
    return sum;
  };
  EXPECT_EQ(r["states"], states_of(r["members"]));
  // without --val every model is a member
  const json all = expect_result(run("identify average --models " + quoted(a) + " " + quoted(lin) + " --out " + quoted(avg)));
  EXPECT_EQ(all["members"].size(), 2u);
  EXPECT_EQ(all["states"], states_of(all["members"]));
  // a NARX model is not averaged: the refusal names the file and its kind
  expect_result(run("identify narx --data " + est() + " --fs 3000 --na 2 --nb 2 --hidden 2 --max-iter 1 "
                                      "--out " + quoted(dir_ / "n.json")));
  const RunResult bad = run("identify average --models " + quoted(a) + " " + quoted(dir_ / "n.json") + " --out " + quoted(avg));
  expect_failure(bad);
  EXPECT_TRUE(contains(bad.err, "n.json") && contains(bad.err, "narx")) << bad.err;
  // nor a model trained on other data (another scaling): the refusal names both files
  const fs::path other = dir_ / "other.json";
  expect_result(run("identify ss --data " + val() + " --fs 3000 --nx 2 --hidden 2 --lags 8 --window 40 --epochs 0 --out " +
                    quoted(other)));
  const RunResult mixed = run("identify average --models " + quoted(a) + " " + quoted(other) + " --out " + quoted(avg));
  expect_failure(mixed);
  EXPECT_TRUE(contains(mixed.err, "other.json cannot be averaged with") && contains(mixed.err, "a.json") &&
              contains(mixed.err, "another scaling"))
      << mixed.err;
}

TEST_F(CliIdentifySs, AFittedInitialStateIsWrittenReadByValidateAndKeptByLaterTraining) {
  const fs::path encoder = dir_ / "enc.json", fitted = dir_ / "fit.json", again = dir_ / "again.json", back = dir_ / "back.json";
  const json enc = trained_params("--nx 4 --hidden 6 --lags 8 --window 40 --epochs 3 --seed 2", encoder);
  EXPECT_FALSE(enc.contains("initial_state"));
  // converted: the same θ, x(0) now fitted to the 50 measured samples; validate's J is the J reported
  const json fit = trained_params("--start-from " + quoted(encoder) + " --epochs 0 --initial-state fit", fitted);
  EXPECT_EQ(fit["theta"], enc["theta"]);
  ASSERT_TRUE(fit.contains("initial_state"));
  EXPECT_EQ(fit["initial_state"]["state_mean"].size(), enc["states"].get<std::size_t>());
  EXPECT_EQ(fit["initial_state"]["state_covariance"].size(), enc["states"].get<std::size_t>());
  EXPECT_EQ(json::parse(text_of(fitted))["meta"]["initial_state"], "fit");
  // the encoder reads 8 samples, the fit sees 50 through the model: its J on the record is lower
  const json v_enc = expect_result(run("validate --model " + quoted(encoder) + " --data " + val() + " --init 50"));
  const json v_fit = expect_result(run("validate --model " + quoted(fitted) + " --data " + val() + " --init 50"));
  EXPECT_LT(v_fit["J_sim_pct"].get<double>(), v_enc["J_sim_pct"].get<double>());
  // trained on from it, the fit stays unless told otherwise
  trained_params("--start-from " + quoted(fitted) + " --window 40 --epochs 1 --seed 3", again);
  EXPECT_EQ(json::parse(text_of(again))["meta"]["initial_state"], "fit");
  EXPECT_TRUE(json::parse(text_of(again))["params"].contains("initial_state"));
  trained_params("--start-from " + quoted(fitted) + " --epochs 0 --initial-state encoder", back);
  EXPECT_FALSE(json::parse(text_of(back))["params"].contains("initial_state"));
  const RunResult bad = run("identify ss --data " + est() + " --fs 3000 --start-from " + quoted(encoder) +
                            " --epochs 0 --initial-state guess --out " + quoted(dir_ / "bad.json"));
  expect_usage_error(bad);
  EXPECT_TRUE(contains(bad.err, "--initial-state")) << bad.err;
}

TEST_F(CliIdentifySs, CubicStatesOnlyNodesAreWrittenAndValidateReadsThem) {
  const json params = trained_params("--nx 2 --hidden 2 --activation cubic --hidden-states-only --lags 8 --window 40 "
                                     "--epochs 2 --seed 1", dir_ / "lfr.json");
  EXPECT_EQ(params["activation"], "cubic");
  EXPECT_EQ(params["hidden_input"], false);
  const RunResult bad = run("identify ss --data " + est() + " --fs 3000 --nx 2 --hidden 2 --activation relu --out " +
                            quoted(dir_ / "bad.json"));
  expect_usage_error(bad);
  EXPECT_TRUE(contains(bad.err, "--activation")) << bad.err;
}

TEST_F(CliIdentifySs, PolynomialOfTheLeadingStatesIsWrittenAndMoreThanNxIsRefused) {
  const json params = trained_params("--nx 3 --hidden 0 --poly-degree 3 --poly-states 2 --lags 8 --window 40 "
                                     "--epochs 1 --seed 1", dir_ / "pnlss.json");
  EXPECT_EQ(params["poly_states"], 2);
  EXPECT_EQ(params["poly_input"], false);
  for (const char* extra : {" --nx 2 --poly-degree 3 --poly-states 3", " --nx 3 --poly-states 2"}) {
    const RunResult bad = run("identify ss --data " + est() + " --fs 3000 --hidden 0" + std::string(extra) + " --out " +
                              quoted(dir_ / "bad.json"));
    expect_usage_error(bad);
    EXPECT_TRUE(contains(bad.err, "--poly-states")) << bad.err;
    EXPECT_FALSE(fs::exists(dir_ / "bad.json"));
  }
}

TEST_F(CliIdentifySs, WritesNoFileWhenEveryCandidateRunsAwayInFreeRun) {
  // A stable linear start (its file loads) of gain 1000 in scaled units: full-scale noise drives its free
  // run far past ±100, and a learning rate of 1e-9 keeps every epoch's model there.
  const fs::path linear = dir_ / "lin.json", loud = dir_ / "loud.json", model = dir_ / "ss.json";
  expect_result(run("identify linear --data " + est() + " --fs 3000 --method oe --order 2 --out " + quoted(linear)));
  json lin = json::parse(text_of(linear));
  for (auto& b : lin["params"]["b"]) b = 1000.0 * b.get<double>();
  std::ofstream(loud) << lin.dump();
  const RunResult r = run("identify ss --data " + est() + " --val " + val() + " --fs 3000 --linear " + quoted(loud) +
                          " --hidden 4 --lags 8 --window 40 --epochs 2 --lr 1e-9 --out " + quoted(model));
  // Failed (the epochs' progress lines precede the error), printed no result, wrote no file.
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_FALSE(fs::exists(model));
  for (const char* said : {"free run", "no model written", "nx", "poly_degree", "more estimation data"}) {
    EXPECT_TRUE(contains(r.err, said)) << said << ": " << r.err;
  }
}

TEST_F(CliIdentifySs, BadOptionsFailNamingTheProblem) {
  const RunResult no_linear = run("identify ss --data " + est() + " --fs 3000 --linear " + quoted(dir_ / "none.json") +
                                  " --out " + quoted(dir_ / "ss.json"));
  expect_failure(no_linear);
  EXPECT_TRUE(contains(no_linear.err, "none.json")) << no_linear.err;
  const RunResult long_window = run("identify ss --data " + est() + " --fs 3000 --nx 2 --window 5000 --out " +
                                    quoted(dir_ / "ss.json"));
  expect_failure(long_window);
  EXPECT_TRUE(contains(long_window.err, "window")) << long_window.err;
}

}  // namespace
}  // namespace panelbass

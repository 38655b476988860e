// One verb, two doors, for identify linear, identify narx, analyze and evaluate: the CLI and the API's job run the same
// use case (usecases/identify_linear.h, identify_narx.h, analyze.h, evaluate.h), so given the same record (or model,
// or chain) and no options they make the same model and the same figures, and refuse the same bad input with the same
// words. The CLI runs as a user runs it (the panelbass binary); the job through the job kinds' registry.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "dsp/data_file.h"
#include "models/io/json_file.h"
#include "models/linear/linear_model.h"
#include "models/narx/narx_model.h"
#include "tests/api/jobs/usecase_parity_fixture.h"
#include "tests/api/jobs/job_test_fixture.h"
#include "tests/support/cli_runner.h"
#include "usecases/analyze.h"
#include "usecases/evaluate.h"
#include "usecases/identify_linear.h"
#include "usecases/identify_narx.h"

namespace panelbass::api::job_testing {
namespace {

class IdentifyDoors : public UseCaseParityTest {
 protected:
  // `panelbass <args>` run in the test's folder: its exit status, stdout and stderr.
  testing_support::RunResult panelbass(const std::string& args) { return cli(args); }

  // Runs an excite job `id` (2000 estimation and 1000 validation samples of the reference system) and writes its two
  // parts as est.csv and val.csv (u, y at 3000 Hz; 17 significant digits: the same doubles at both doors).
  void record_in_both(const std::string& id) {
    const json result =
        run("excite", {{"samples", 2000}, {"validation_samples", 1000}, {"amplitude", 0.5}, {"seed", 3}}, id);
    for (const char* part : {"est", "val"}) {
      dsp::Record r;
      r.fs = kFs;
      for (const char* column : {"u", "y"}) {
        const std::vector<double> v = result.at("record").at(std::string(column) + "_" + part).get<std::vector<double>>();
        r.add(column, Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
      }
      dsp::write_data_file(dir_ / (std::string(part) + ".csv"), r);
    }
  }
};

// One refusal, the same words after each door's spelling of the field.
void expect_same_refusal(const std::string& job_message, const testing_support::RunResult& cli, const std::string& param,
                         const std::string& flag, const std::string& words) {
  EXPECT_EQ(cli.status, 2) << cli.err;
  EXPECT_NE(job_message.find("params." + param + ": " + words), std::string::npos) << job_message;
  EXPECT_NE(cli.err.find(flag + ": " + words), std::string::npos) << cli.err;
}

TEST_F(IdentifyDoors, IdentifyLinearMakesTheSameModelFromBothDoors) {
  record_in_both("j2");
  const json job = run("identify-linear", {{"record", "j2"}}, "j3");
  const testing_support::RunResult r = panelbass("identify linear --data est.csv --val val.csv --fs 3000 --out lin.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const models::LinearModel from_cli = models::linear_model_from_json(models::read_json_file(dir_ / "lin.json"));
  const models::LinearModel from_job = models::linear_model_from_json(*store_->model(job.at("model_id")));
  // The defaults written once (IdentifyLinearRequest): the method, the order, the estimated delay.
  EXPECT_EQ(job.at("summary").at("method"), usecases::IdentifyLinearRequest{}.method);
  EXPECT_EQ(from_job.tf.na(), usecases::IdentifyLinearRequest{}.order);
  EXPECT_EQ(from_cli.tf.na(), from_job.tf.na());
  EXPECT_EQ(from_cli.tf.nk, from_job.tf.nk);
  ASSERT_EQ(from_cli.tf.b.size(), from_job.tf.b.size());
  EXPECT_LE((from_cli.tf.a - from_job.tf.a).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LE((from_cli.tf.b - from_job.tf.b).cwiseAbs().maxCoeff(), 1e-9);
  // The same figures: the job's summary is what the CLI prints, but where each door keeps things.
  EXPECT_EQ(without(job.at("summary"), {"data", "history_source"}), without(json::parse(r.out), {"out"}));
  EXPECT_EQ(job.at("j_val_pct"), job.at("summary").at("J_val_pct"));

  const std::string refused = refusal("identify-linear", {{"record", "j2"}, {"order", 201}});
  const testing_support::RunResult bad = panelbass("identify linear --data est.csv --fs 3000 --order 201 --out bad.json");
  expect_same_refusal(refused, bad, "order", "--order", "must be within 1..200, got 201");
  const std::string no_val = refusal("identify-linear", {{"excite", {{"validation_samples", 0}}}, {"scan", {2, 4}}});
  const testing_support::RunResult cli_no_val = panelbass("identify linear --data est.csv --fs 3000 --scan 2:4 --out bad.json");
  expect_same_refusal(no_val, cli_no_val, "scan", "--scan", "an order scan needs validation data");
}

TEST_F(IdentifyDoors, IdentifyNarxMakesTheSameModelFromBothDoors) {
  // A short training (3 iterations a mode; everything else the defaults) from both doors: the same weights.
  record_in_both("j2");
  // The defaults written once: the job's params given none are the request's (the documented recipe).
  const json filled = validate_job_params("identify-narx", {{"record", "j2"}}, env_);
  EXPECT_EQ(filled.at("na"), 8);
  EXPECT_EQ(filled.at("nb"), 8);
  EXPECT_EQ(filled.at("hidden"), json({17}));
  EXPECT_EQ(filled.at("max_iterations"), 100);
  const json defaults = usecases::to_json(usecases::IdentifyNarxRequest{});
  for (const auto& [field, value] : defaults.items()) {
    if (field != "record") EXPECT_EQ(filled.at(field), value) << field;
  }

  const json job = run("identify-narx", {{"record", "j2"}, {"max_iterations", 3}}, "j3");
  const testing_support::RunResult r =
      panelbass("identify narx --data est.csv --val val.csv --fs 3000 --max-iter 3 --out narx.json --history h.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const models::NarxModel from_cli = models::narx_model_from_json(models::read_json_file(dir_ / "narx.json"));
  const models::NarxModel from_job = models::narx_model_from_json(*store_->model(job.at("model_id")));
  EXPECT_EQ(from_job.structure.na, 8);
  EXPECT_EQ(from_job.structure.hidden, std::vector<int>{17});
  EXPECT_EQ(from_cli.structure.nk, from_job.structure.nk);
  ASSERT_EQ(from_cli.net.parameters().size(), from_job.net.parameters().size());
  EXPECT_LE((from_cli.net.parameters() - from_job.net.parameters()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(from_cli.meta.at("history").size(), from_job.meta.at("history").size());
  const json printed = json::parse(r.out);
  EXPECT_EQ(without(job.at("summary"), {"data", "seconds"}), without(printed, {"out", "history_out", "seconds"}));
  // The weight decay re-estimated by the evidence is the default at both doors (the best recipe measured).
  EXPECT_EQ(usecases::evidence_decay_of(usecases::IdentifyNarxRequest{}), "all");
  EXPECT_EQ(job.at("summary").at("evidence_decay"), "all");
  EXPECT_EQ(printed.at("evidence_decay"), "all");

  const std::string refused = refusal("identify-narx", {{"record", "j2"}, {"na", 501}});
  const testing_support::RunResult bad = panelbass("identify narx --data est.csv --fs 3000 --na 501 --out bad.json");
  expect_same_refusal(refused, bad, "na", "--na", "must be within 0..500, got 501");
  const std::string modes = refusal("identify-narx", {{"record", "j2"}, {"modes", {"pem", "gradient"}}});
  const testing_support::RunResult bad_modes = panelbass("identify narx --data est.csv --fs 3000 --train pem,gradient --out bad.json");
  expect_same_refusal(modes, bad_modes, "modes", "--train", "must be pem, oem-s, oem-d, oem-n or oem-ms, got \"gradient\"");
  const std::string rule = refusal("identify-narx", {{"record", "j2"}, {"evidence_decay", "always"}});
  const testing_support::RunResult bad_rule = panelbass("identify narx --data est.csv --fs 3000 --evidence-decay always --out bad.json");
  expect_same_refusal(rule, bad_rule, "evidence_decay", "--evidence-decay", "must be off, all or oem, got \"always\"");
  // Steepest descent has no decay: its default rule is off, and asking for the evidence with it is refused.
  usecases::IdentifyNarxRequest sd;
  sd.optimizer = "sd";
  EXPECT_EQ(usecases::evidence_decay_of(sd), "off");
  EXPECT_NO_THROW(validate_job_params("identify-narx", {{"record", "j2"}, {"optimizer", "sd"}}, env_));
  const std::string sd_all = refusal("identify-narx", {{"record", "j2"}, {"optimizer", "sd"}, {"evidence_decay", "all"}});
  const testing_support::RunResult bad_sd =
      panelbass("identify narx --data est.csv --fs 3000 --optimizer sd --evidence-decay all --out bad.json");
  expect_same_refusal(sd_all, bad_sd, "evidence_decay", "--evidence-decay",
                      "needs the lm optimizer (the evidence is read off its Gauss-Newton matrix), the optimizer is sd: "
                      "leave it out or give off");
}

TEST_F(IdentifyDoors, AnalyzeGivesTheSameFiguresFromBothDoors) {
  const std::string id = store_reference_model();
  models::write_json_file(dir_ / "lin.json", *store_->model(id));
  record_in_both("j2");
  const json job = run("analyze", {{"model", id}, {"record", "j2"}}, "j3");
  const testing_support::RunResult r = panelbass("analyze --model lin.json --data val.csv --fs 3000 --out report.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  // The job analyses the record's validation part, as the CLI val.csv; the same request defaults (init 50, 20 lags,
  // 20 refinement iterations) and no plant: the same report but the names of model and record.
  EXPECT_EQ(printed.at("init"), usecases::AnalyzeRequest{}.init);
  EXPECT_EQ(without(job.at("summary"), {"model", "data"}), without(printed, {"model", "data", "out", "html", "plots"}));
  EXPECT_EQ(job.at("j_val_pct"), printed.at("J_sim_pct"));

  const std::string refused = refusal("analyze", {{"model", id}, {"record", "j2"}, {"lags", 0}});
  const testing_support::RunResult bad = panelbass("analyze --model lin.json --data val.csv --fs 3000 --lags 0 --out bad.json");
  expect_same_refusal(refused, bad, "lags", "--lags", "must be within 1..10000, got 0");
}

TEST_F(IdentifyDoors, EvaluateGivesTheSameTableFromBothDoors) {
  // The defaults written once: the job's params given none are the request's, but the plant (the server's own when it
  // runs one; this one runs none, so the CLI's default preset).
  const std::string ff = run("design-lq", {{"plant_model", store_reference_model()}}, "j1").at("model_id");
  const json filled = validate_job_params("evaluate", {{"feedforward_model", ff}}, env_);
  const json defaults = usecases::to_json(usecases::EvaluateRequest{});
  for (const auto& [field, value] : defaults.items()) {
    EXPECT_EQ(filled.at(field), value) << field;
  }
  // The chain the job builds of the stored controller is `panelbass chain --ff`'s (its design's 20-1200 Hz band-pass).
  models::write_json_file(dir_ / "ff.json", *store_->model(ff));
  ASSERT_EQ(panelbass("chain --ff ff.json --out chain.json").status, 0);
  const json job = run("evaluate", {{"feedforward_model", ff}, {"plant", "linear"}, {"probes_hz", {160.0}},
                                    {"noise_samples", 4096}}, "j2");
  const testing_support::RunResult r =
      panelbass("evaluate --chain chain.json --plant linear --probes 160 --noise-samples 4096");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  EXPECT_EQ(job.at("rows"), without_non_finite(printed.at("rows")));
  EXPECT_EQ(job.at("summary").at("noise_amplitude"), printed.at("noise_amplitude"));
  EXPECT_EQ(job.at("summary").at("jc_noise_floor_pct"), printed.at("jc_noise_floor_pct"));
  EXPECT_EQ(job.at("summary").at("plant"), printed.at("plant"));

  const std::string refused = refusal("evaluate", {{"feedforward_model", ff}, {"probe_peak", 1.5}});
  const testing_support::RunResult bad = panelbass("evaluate --chain chain.json --probe-peak 1.5");
  expect_same_refusal(refused, bad, "probe_peak", "--probe-peak", "must be within [0, 1], got 1.5");
}

}  // namespace
}  // namespace panelbass::api::job_testing

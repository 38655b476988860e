// One verb, two doors: the CLI and the API's job run the same use case (usecases/), so given the same model and no
// options they make the same controller and the same figures, and refuse the same bad input with the same words.
// The CLI runs as a user runs it (the panelbass binary); the job through the job kinds' registry.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include "dsp/data_file.h"
#include "models/io/json_file.h"
#include "tests/api/jobs/job_test_fixture.h"
#include "tests/support/cli_runner.h"
#include "usecases/design_lq.h"

namespace panelbass::api::job_testing {
namespace {

// The samples of array `a` (an excite job's record column).
Eigen::VectorXd samples_of(const json& a) {
  const std::vector<double> v = a.get<std::vector<double>>();
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

class UseCaseParity : public JobKindsTest {
 protected:
  // `panelbass <args>` in the test's folder; its exit status, stdout and stderr.
  testing_support::RunResult cli(const std::string& args) {
    const std::filesystem::path out = dir_ / "cli-out.txt", err = dir_ / "cli-err.txt";
    const std::string command = "cd " + testing_support::quoted(dir_) + " && " +
                                testing_support::quoted(std::string(PANELBASS_BIN)) + " " + args + " </dev/null >" +
                                testing_support::quoted(out) + " 2>" + testing_support::quoted(err);
    const int raw = std::system(command.c_str());
    testing_support::RunResult r;
    r.status = (raw != -1 && WIFEXITED(raw)) ? WEXITSTATUS(raw) : -1;
    r.out = text_of(out);
    r.err = text_of(err);
    return r;
  }

  // Stores the reference model and writes the same file as lin.json; returns its id.
  std::string reference_model_in_both() {
    const std::string id = store_reference_model();
    models::write_json_file(dir_ / "lin.json", *store_->model(id));
    return id;
  }
};

TEST_F(UseCaseParity, DesignLqWithNoOptionsMakesTheSameControllerFromBothDoors) {
  const std::string id = reference_model_in_both();
  const json job = run("design-lq", {{"plant_model", id}}, "j1");
  const models::LqFeedforward from_job = models::lq_feedforward_from_json(*store_->model(job.at("model_id")));

  const testing_support::RunResult r = cli("design lq --model lin.json --out ff.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  const models::LqFeedforward from_cli = models::lq_feedforward_from_json(models::read_json_file(dir_ / "ff.json"));

  // The defaults written once: models::LqWeights's R = 3 and R0 = 20 at both doors.
  EXPECT_EQ(from_job.weights.R, models::LqWeights{}.R);
  EXPECT_EQ(from_job.weights.R0, models::LqWeights{}.R0);
  EXPECT_EQ(from_cli.weights.R, from_job.weights.R);
  EXPECT_EQ(from_cli.weights.R0, from_job.weights.R0);
  ASSERT_EQ(from_cli.L.size(), from_job.L.size());
  EXPECT_LE((from_cli.L - from_job.L).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(from_cli.meta.at("max_input"), from_job.meta.at("max_input"));
  EXPECT_EQ(from_cli.meta.at("bandpass"), from_job.meta.at("bandpass"));
  // The same figures: the job's summary is what the CLI prints (but where each door keeps the controller).
  json summary = job.at("summary"), result = printed;
  for (json* j : {&summary, &result}) {
    for (const char* door_only : {"plant_model", "out", "plots"}) j->erase(door_only);
  }
  EXPECT_EQ(summary, result);
}

TEST_F(UseCaseParity, DesignLqRefusesTheSameBadInputWithTheSameWordsAtBothDoors) {
  const std::string id = reference_model_in_both();
  const std::string job = refusal("design-lq", {{"plant_model", id}, {"r0", -1}});
  const testing_support::RunResult r = cli("design lq --model lin.json --R0 -1 --out ff.json");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(job.find("params.r0: must be ≥ 0, got -1"), std::string::npos) << job;
  EXPECT_NE(r.err.find("--R0: must be ≥ 0, got -1"), std::string::npos) << r.err;

  const std::string both = refusal("design-lq", {{"plant_model", id}, {"r", 1.0}, {"max_input", 0.3}});
  EXPECT_NE(both.find("params.max_input: choose the weight by r or by max_input, not both"), std::string::npos) << both;
  const std::string too_high = refusal("design-lq", {{"plant_model", id}, {"band_pass", {{"high_hz", 1600}}}});
  const testing_support::RunResult high = cli("design lq --model lin.json --bandpass 20,1600 --out ff.json");
  EXPECT_NE(too_high.find("params.band_pass.high_hz: 1600 Hz is not below the model's Nyquist frequency 1500 Hz"),
            std::string::npos)
      << too_high;
  EXPECT_NE(high.err.find("--bandpass: 1600 Hz is not below the model's Nyquist frequency 1500 Hz"), std::string::npos)
      << high.err;
}

TEST_F(UseCaseParity, ValidateGivesTheSameJFromBothDoors) {
  const std::string id = reference_model_in_both();
  const json record = run("excite", {{"samples", 2000}, {"validation_samples", 1000}, {"amplitude", 0.5}, {"seed", 3}}, "j2");
  const json job = run("validate", {{"model", id}, {"record", "j2"}, {"init", 10}}, "j3");

  dsp::Record val;
  val.fs = kFs;
  val.add("u", samples_of(record.at("record").at("u_val")));
  val.add("y", samples_of(record.at("record").at("y_val")));
  dsp::write_data_file(dir_ / "val.csv", val);
  const testing_support::RunResult r = cli("validate --model lin.json --data val.csv --fs 3000 --init 10");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  // CSV keeps 17 significant digits: the same record, so the same J to rounding.
  EXPECT_NEAR(printed.at("J_sim_pct").get<double>(), job.at("j_val_pct").get<double>(), 1e-9);
  EXPECT_NEAR(printed.at("J_sim_pct").get<double>(), job.at("summary").at("J_sim_pct").get<double>(), 1e-9);
  EXPECT_NEAR(printed.at("J_pred_pct").get<double>(), job.at("summary").at("J_pred_pct").get<double>(), 1e-9);
  EXPECT_EQ(printed.at("samples"), job.at("summary").at("samples"));
  // An init as long as the record: refused by both doors with the same words.
  const std::string refused = one_line_error<std::invalid_argument>([&] {
    run("validate", {{"model", id}, {"record", "j2"}, {"init", 1000}}, "j4");
  });
  const testing_support::RunResult cli_refused = cli("validate --model lin.json --data val.csv --fs 3000 --init 1000");
  EXPECT_NE(refused.find("params.init: 1000 is not shorter than the data (1000 samples)"), std::string::npos) << refused;
  EXPECT_NE(cli_refused.err.find("--init: 1000 is not shorter than the data (1000 samples)"), std::string::npos)
      << cli_refused.err;
}

}  // namespace
}  // namespace panelbass::api::job_testing

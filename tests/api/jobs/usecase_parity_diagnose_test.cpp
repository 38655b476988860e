// One verb, two doors, for diagnose: the CLI and the API's diagnose job run the same use case (usecases/diagnose.h),
// so on the same record with no options they start from the same defaults, find the same physics with the same J
// before and after, and refuse the same bad settings with the same words.
// The CLI runs as a user runs it (the panelbass binary); the job through the job kinds' registry.
#include <gtest/gtest.h>

#include <string>

#include "dsp/data_file.h"
#include "models/io/json_file.h"
#include "tests/api/jobs/usecase_parity_fixture.h"
#include "usecases/diagnose.h"

namespace panelbass::api::job_testing {
namespace {

class DiagnoseParity : public UseCaseParityTest {
 protected:
  // A record of the virtual transducer made by excite job `id`, its two parts written as est.csv and val.csv (u, y
  // at 3000 Hz; CSV keeps 17 significant digits, so both doors read the same doubles).
  void record_in_both(const std::string& id) {
    use_plant("panel-exciter");
    const json excited = run("excite", {{"samples", 3000}, {"validation_samples", 2000}, {"amplitude", 0.8}, {"seed", 4}}, id);
    for (const char* part : {"est", "val"}) {
      dsp::Record r;
      r.fs = kFs;
      r.add("u", samples_of(excited.at("record").at(std::string("u_") + part)));
      r.add("y", samples_of(excited.at("record").at(std::string("y_") + part)));
      dsp::write_data_file(dir_ / (std::string(part) + ".csv"), r);
    }
  }
};

TEST_F(DiagnoseParity, TheJobsDefaultsAreTheRequestsAndTheCommandLinesToo) {
  record_in_both("j1");
  const json filled = validate_job_params("diagnose", {{"record", "j1"}}, env_);
  const json defaults = usecases::to_json(usecases::DiagnoseRequest{});
  for (const auto& [field, value] : defaults.items()) {
    if (field == "baseline_model") continue;  // none given: the order scan's model
    EXPECT_EQ(filled.at(field), value) << field;
  }
  // The command line's help shows the defaults it starts from: the same struct's.
  const testing_support::RunResult help = cli("diagnose --help");
  ASSERT_EQ(help.status, 0) << help.err;
  const usecases::DiagnoseRequest d;
  for (const std::string& shown : {"--init INT=" + std::to_string(d.init), "--scan-from INT=" + std::to_string(d.scan_from),
                                  "--scan-to INT=" + std::to_string(d.scan_to),
                                  "--max-findings INT=" + std::to_string(d.max_findings), "--sensor TEXT=" + d.sensor,
                                  std::string("--current-col TEXT=") + (d.use_current ? "auto" : "none")})
    EXPECT_NE(help.out.find(shown), std::string::npos) << shown << "\n" << help.out;
}

TEST_F(DiagnoseParity, BothDoorsFindTheSamePhysicsOnTheSameRecord) {
  record_in_both("j1");
  const json job = run("diagnose", {{"record", "j1"}, {"max_findings", 1}, {"scan_from", 4}, {"scan_to", 4}}, "j2");
  const testing_support::RunResult r =
      cli("diagnose --data est.csv --val val.csv --fs 3000 --max-findings 1 --scan-from 4 --scan-to 4 --out report.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const json report = models::read_json_file(dir_ / "report.json");
  // The same baseline from the same scan, the same J before and after, to rounding.
  for (const char* key : {"na", "nb", "nk"}) EXPECT_EQ(report.at("baseline").at(key), job.at("baseline").at(key)) << key;
  for (const char* key : {"J_val_before_pct", "J_val_after_pct", "noise_floor_pct"}) {
    const double a = report.at(key).get<double>(), b = job.at(key).get<double>();
    EXPECT_NEAR(a, b, 1e-9 * std::max(1.0, std::abs(b))) << key;
  }
  // The same findings, named and qualified in the same words.
  ASSERT_EQ(report.at("findings").size(), job.at("findings").size()) << r.out;
  ASSERT_FALSE(job.at("findings").empty()) << "the virtual transducer's nonlinearity is above its noise: " << job.dump(1);
  for (std::size_t k = 0; k < job.at("findings").size(); ++k) {
    const json& a = report.at("findings")[k];
    const json& b = job.at("findings")[k];
    EXPECT_EQ(a.at("effect"), b.at("effect")) << k;
    EXPECT_EQ(a.at("explanation"), b.at("explanation")) << k;
    EXPECT_EQ(a.at("confidence").at("sentence"), b.at("confidence").at("sentence")) << k;
  }
  EXPECT_EQ(report.at("channels"), job.at("channels"));
}

TEST_F(DiagnoseParity, BothDoorsRefuseTheSameBadSettingsWithTheSameWords) {
  record_in_both("j1");
  struct Bad {
    json param;           ///< one bad param for the job
    std::string flags;    ///< the same on the command line
    std::string words;    ///< what both say after the field
    std::string job_field, cli_flag;
  };
  const std::vector<Bad> bad = {
      {{{"max_findings", 21}}, "--max-findings 21", "must be within 0..20, got 21", "params.max_findings", "--max-findings"},
      {{{"sensor", "pressure"}}, "--sensor pressure",
       "must be one of unknown, displacement, velocity, acceleration, got \"pressure\"", "params.sensor", "--sensor"},
      {{{"scan_from", 6}, {"scan_to", 3}}, "--scan-from 6 --scan-to 3", "6 is above the highest order scanned, 3",
       "params.scan_from", "--scan-from"},
      {{{"init", -1}}, "--init -1", "must be within 0..100000000, got -1", "params.init", "--init"},
  };
  for (const Bad& b : bad) {
    json params = b.param;
    params["record"] = "j1";
    const std::string job = refusal("diagnose", params);
    const testing_support::RunResult c = cli("diagnose --data est.csv --val val.csv --fs 3000 " + b.flags + " --out r.json");
    EXPECT_EQ(c.status, 2) << c.err;
    EXPECT_NE(job.find(b.job_field + ": " + b.words), std::string::npos) << job;
    EXPECT_NE(c.err.find(b.cli_flag + ": " + b.words), std::string::npos) << c.err;
  }
  // An init that leaves too little to judge is known only with the record: refused by the job's work, the same words.
  const std::string job = one_line_error<std::invalid_argument>([&] { run("diagnose", {{"record", "j1"}, {"init", 1900}}, "j2"); });
  const testing_support::RunResult c = cli("diagnose --data est.csv --val val.csv --fs 3000 --init 1900 --out r.json");
  EXPECT_EQ(c.status, 2) << c.err;
  const std::string words = "1900 leaves fewer than 512 of the 2000 validation samples to judge";
  EXPECT_NE(job.find("params.init: " + words), std::string::npos) << job;
  EXPECT_NE(c.err.find("--init: " + words), std::string::npos) << c.err;
}

}  // namespace
}  // namespace panelbass::api::job_testing

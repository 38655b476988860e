#pragma once
// The two doors of a use case side by side in a test: the API's jobs through the job kinds' registry (JobKindsTest)
// and the CLI as a user runs it (the panelbass binary in the test's folder).

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "tests/api/jobs/job_test_fixture.h"
#include "tests/support/cli_runner.h"

namespace panelbass::api::job_testing {

/// The samples of array `a` (an excite job's record column).
inline Eigen::VectorXd samples_of(const json& a) {
  const std::vector<double> v = a.get<std::vector<double>>();
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

/// A job kinds test that also runs the CLI.
class UseCaseParityTest : public JobKindsTest {
 protected:
  /// `panelbass <args>` in the test's folder; its exit status, stdout and stderr.
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
};

}  // namespace panelbass::api::job_testing

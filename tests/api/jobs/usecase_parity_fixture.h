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

/// `j` without the keys only one door has (where a model went, what a file or a stored model is called, timing).
inline json without(json j, const std::vector<std::string>& keys) {
  for (const std::string& k : keys) j.erase(k);
  return j;
}

/// A job kinds test that also runs the CLI.
class UseCaseParityTest : public JobKindsTest {
 protected:
  /// `panelbass <args>` in the test's folder; its exit status, stdout and stderr.
  testing_support::RunResult cli(const std::string& args) { return testing_support::run_panelbass_in(dir_, args); }
};

}  // namespace panelbass::api::job_testing

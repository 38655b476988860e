#pragma once
// Running the real `panelbass` binary from a test: exit status, stdout and stderr, and the CLI
// contract (one JSON object on success; one "panelbass: error:" line and exit 1 on failure; exit 2 for
// bad usage).

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/support/scratch_directory.h"
#include "tests/support/text.h"

namespace panelbass::testing_support {

namespace fs = std::filesystem;
using nlohmann::json;

/// What one run of the command left behind.
struct RunResult {
  int status = -1;  ///< exit status, or -1 if it did not exit normally
  std::string out;  ///< standard output
  std::string err;  ///< standard error
};

/// `text` as one word for /bin/sh.
inline std::string quoted(const std::string& text) {
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

inline std::string quoted(const fs::path& path) { return quoted(path.string()); }

/// Runs `panelbass <args>` (args already quoted for the shell) in folder `dir` (relative paths are its), with stdin
/// from /dev/null and its output captured in files there.
inline RunResult run_panelbass_in(const fs::path& dir, const std::string& args) {
  const fs::path out = dir / "cli-out.txt", err = dir / "cli-err.txt";
  const std::string command = "cd " + quoted(dir) + " && " + quoted(std::string(PANELBASS_BIN)) + " " + args +
                              " </dev/null >" + quoted(out) + " 2>" + quoted(err);
  const int raw = std::system(command.c_str());
  RunResult r;
  r.status = (raw != -1 && WIFEXITED(raw)) ? WEXITSTATUS(raw) : -1;
  const auto bytes = [](const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  r.out = bytes(out);
  r.err = bytes(err);
  return r;
}

/// A fresh directory per test (removed afterwards) and a way to run the binary with its output
/// captured in files there.
class CliTest : public ScratchDirectoryTest {
 protected:
  /// Runs `panelbass <args>` (args already quoted for the shell) with stdin from /dev/null.
  RunResult run(const std::string& args) {
    const std::string n = std::to_string(++runs_);
    const fs::path out = dir_ / ("stdout-" + n + ".txt");
    const fs::path err = dir_ / ("stderr-" + n + ".txt");
    const std::string command =
        quoted(std::string(PANELBASS_BIN)) + " " + args + " </dev/null >" + quoted(out) + " 2>" + quoted(err);
    const int raw = std::system(command.c_str());
    RunResult r;
    r.status = (raw != -1 && WIFEXITED(raw)) ? WEXITSTATUS(raw) : -1;
    r.out = text_of(out);
    r.err = text_of(err);
    return r;
  }

  /// Splits the CSV `all` (header + rows) into `est.csv` (its first `rows` rows) and `val.csv` (the
  /// rest, with the header) in the test directory.
  void split_csv(const fs::path& all, int rows) const {
    const std::string text = text_of(all);
    std::size_t pos = text.find('\n') + 1;
    const std::string header = text.substr(0, pos);
    for (int row = 0; row < rows; ++row) pos = text.find('\n', pos) + 1;
    file("est.csv", text.substr(0, pos));
    file("val.csv", header + text.substr(pos));
  }

  int runs_ = 0;
};


/// The run succeeded and printed exactly one JSON object on stdout; returns it.
inline json expect_result(const RunResult& r) {
  EXPECT_EQ(r.status, 0) << "stderr: " << r.err;
  json result;
  try {
    result = json::parse(r.out);
  } catch (const json::exception& e) {
    ADD_FAILURE() << "stdout is not one JSON value (" << e.what() << "): " << r.out;
    return json::object();
  }
  EXPECT_TRUE(result.is_object()) << r.out;
  return result;
}

/// The run failed (exit 1), printed nothing on stdout, and exactly one line on stderr: the error.
inline void expect_failure(const RunResult& r) {
  EXPECT_EQ(r.status, 1) << "stdout: " << r.out << "\nstderr: " << r.err;
  EXPECT_EQ(r.out, "") << "a failed command printed a result";
  EXPECT_EQ(r.err.rfind("panelbass: error: ", 0), 0u) << "stderr: " << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "stderr is not one line: " << r.err;
  EXPECT_TRUE(!r.err.empty() && r.err.back() == '\n') << "stderr: " << r.err;
}

/// The run was refused as bad usage (exit 2) before doing anything.
inline void expect_usage_error(const RunResult& r) {
  EXPECT_EQ(r.status, 2) << "stdout: " << r.out << "\nstderr: " << r.err;
  EXPECT_EQ(r.out, "") << "bad usage printed a result";
  EXPECT_FALSE(r.err.empty()) << "bad usage said nothing";
}

/// A test directory holding 6000 samples of the panel exciter: rows 0..4000 in est.csv, the rest in val.csv.
class CliExciterSplitTest : public CliTest {
 protected:
  void SetUp() override {
    expect_result(run("simulate --samples 6000 --seed 5 --out " + quoted(dir_ / "all.csv")));
    split_csv(dir_ / "all.csv", 4000);
  }
  std::string est() const { return quoted(dir_ / "est.csv"); }
  std::string val() const { return quoted(dir_ / "val.csv"); }
};

}  // namespace panelbass::testing_support

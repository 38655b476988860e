#pragma once
// A test fixture that gives each test a fresh directory of its own, removed when the test ends.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <system_error>

namespace panelbass::testing_support {

/// A fresh directory for one test, removed afterwards; derive a suite's fixture from it.
class ScratchDirectoryTest : public ::testing::Test {
 protected:
  /// Creates `dir_` under the system temp directory, named by suite, test, process id and a random number.
  ScratchDirectoryTest() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("panelbass-" + std::string(info->test_suite_name()) + "-" + info->name() + "-" +
            std::to_string(::getpid()) + "-" + std::to_string(std::random_device{}()));
    std::filesystem::create_directories(dir_);
  }

  /// Removes `dir_` and everything in it, ignoring errors.
  ~ScratchDirectoryTest() override {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }

  /// Writes `content` byte for byte to a file in the test directory and returns its path.
  std::filesystem::path file(const std::string& name, const std::string& content) const {
    const std::filesystem::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << content;
    return path;
  }

  /// The bytes of the file at `path` ("" if it cannot be read).
  static std::string text_of(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }

  /// The test's own directory.
  std::filesystem::path dir_;
};

}  // namespace panelbass::testing_support

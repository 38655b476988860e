#include "api/atomic_file.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "tests/support/expect_error.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::api {
namespace {

using testing_support::one_line_error;

class AtomicFileTest : public testing_support::ScratchDirectoryTest {
 protected:
  // Every name in the test folder, for checking that no temporary file is left.
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const auto& entry : std::filesystem::directory_iterator(dir_)) out.push_back(entry.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
  }
};

TEST_F(AtomicFileTest, WritesANewFile) {
  const auto path = dir_ / "a.json";
  write_file_atomically(path, "{\"x\":1}");
  EXPECT_EQ(text_of(path), "{\"x\":1}");
  EXPECT_EQ(names(), std::vector<std::string>{"a.json"});
}

TEST_F(AtomicFileTest, ReplacesTheContentOfAnExistingFile) {
  const auto path = file("a.json", "old content that is longer than the new one");
  write_file_atomically(path, "new");
  EXPECT_EQ(text_of(path), "new");
  EXPECT_EQ(names(), std::vector<std::string>{"a.json"});
}

TEST_F(AtomicFileTest, WritesBinaryAndEmptyContentExactly) {
  const std::string bytes("a\0b\n\r\xff", 6);
  write_file_atomically(dir_ / "bin", bytes);
  EXPECT_EQ(text_of(dir_ / "bin"), bytes);
  write_file_atomically(dir_ / "bin", "");
  EXPECT_EQ(text_of(dir_ / "bin"), "");
}

TEST_F(AtomicFileTest, ATargetThatIsAFolderKeepsItsContentAndNoTemporaryFileIsLeft) {
  // rename() cannot replace a non-empty folder by a file: the last step fails.
  std::filesystem::create_directory(dir_ / "target");
  file("target/inside", "kept");
  const std::string message = one_line_error<StoreError>([&] { write_file_atomically(dir_ / "target", "new"); });
  EXPECT_NE(message.find((dir_ / "target").string()), std::string::npos) << message;
  EXPECT_EQ(text_of(dir_ / "target" / "inside"), "kept");
  EXPECT_EQ(names(), std::vector<std::string>{"target"});
}

TEST_F(AtomicFileTest, AMissingFolderIsReportedWithThePathAndTheReason) {
  const auto path = dir_ / "missing" / "a.json";
  const std::string message = one_line_error<StoreError>([&] { write_file_atomically(path, "x"); });
  EXPECT_NE(message.find((dir_ / "missing").string()), std::string::npos) << message;
  EXPECT_NE(message.find(std::strerror(ENOENT)), std::string::npos) << message;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "missing"));
}

TEST_F(AtomicFileTest, ReadsAWholeFile) {
  std::string big(200000, 'x');
  big[123456] = 'y';
  const auto path = file("big", big);
  EXPECT_EQ(read_whole_file(path), big);
}

TEST_F(AtomicFileTest, ReadErrorsNameThePath) {
  const auto missing = dir_ / "nope.json";
  const std::string message = one_line_error<StoreError>([&] { read_whole_file(missing); });
  EXPECT_NE(message.find(missing.string()), std::string::npos) << message;
  EXPECT_NE(message.find(std::strerror(ENOENT)), std::string::npos) << message;

  const std::string folder = one_line_error<StoreError>([&] { read_whole_file(dir_); });
  EXPECT_NE(folder.find(dir_.string()), std::string::npos) << folder;
  EXPECT_NE(folder.find(std::strerror(EISDIR)), std::string::npos) << folder;
}

}  // namespace
}  // namespace panelbass::api

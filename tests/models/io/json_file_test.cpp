// read_json_file: a JSON file handed to the CLI is read with the limits the API puts on JSON from outside
// (models/io/bounded_json): nesting counted while parsing and a key given twice refused, each naming the file.
#include "models/io/json_file.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "models/io/bounded_json.h"
#include "tests/support/expect_error.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::models {
namespace {

class JsonFileTest : public testing_support::ScratchDirectoryTest {
 protected:
  // Writes `text` to `name` in the test's folder; returns its path.
  std::filesystem::path written(const std::string& name, const std::string& text) const {
    const std::filesystem::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
};

// `levels` nested arrays around a 1: "[[[1]]]" is 3 levels.
std::string nested(std::size_t levels) { return std::string(levels, '[') + "1" + std::string(levels, ']'); }

TEST_F(JsonFileTest, ReadsAFileAtTheNestingLimit) {
  const nlohmann::json j = read_json_file(written("deep.json", nested(kMaxJsonDepth)));
  const nlohmann::json* at = &j;
  for (std::size_t k = 0; k < kMaxJsonDepth; ++k) {
    ASSERT_TRUE(at->is_array());
    at = &at->at(0);
  }
  EXPECT_EQ(*at, 1);
}

TEST_F(JsonFileTest, RefusesNestingBeyondTheLimitNamingTheFile) {
  const std::filesystem::path path = written("deeper.json", nested(kMaxJsonDepth + 1));
  const std::string what = testing_support::one_line_error<ConfigError>([&] { read_json_file(path); });
  EXPECT_NE(what.find(path.string() + ": not acceptable JSON: nesting deeper than 64 levels"), std::string::npos) << what;
  // 50 000 levels (the body that once killed the server) fails as fast, without building them.
  EXPECT_THROW(read_json_file(written("hostile.json", std::string(50'000, '['))), ConfigError);
}

TEST_F(JsonFileTest, RefusesAKeyGivenTwiceNamingIt) {
  const std::filesystem::path path = written("twice.json", R"({"kind":"linear","fs":3000,"kind":"narx"})");
  const std::string what = testing_support::one_line_error<ConfigError>([&] { read_json_file(path); });
  EXPECT_NE(what.find(path.string() + ": not acceptable JSON: duplicate key \"kind\""), std::string::npos) << what;
}

TEST_F(JsonFileTest, MalformedTextIsStillNamedAsBefore) {
  const std::filesystem::path path = written("bad.json", "{\"a\":");
  const std::string what = testing_support::one_line_error<ConfigError>([&] { read_json_file(path); });
  EXPECT_NE(what.find(path.string() + ": not valid JSON"), std::string::npos) << what;
}

}  // namespace
}  // namespace panelbass::models

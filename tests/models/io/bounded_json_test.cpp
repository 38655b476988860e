// parse_bounded_json (models/io/bounded_json.h): the same value as nlohmann's parser for ordinary text, nesting
// refused one level past the limit while parsing, a repeated key named with the path of its object.
#include <gtest/gtest.h>

#include <string>

#include "models/io/bounded_json.h"

namespace panelbass::models {
namespace {

// `levels` nested arrays around 1: "[[1]]" for 2.
std::string nested_arrays(int levels) { return std::string(static_cast<std::size_t>(levels), '[') + "1" + std::string(static_cast<std::size_t>(levels), ']'); }

std::string message_of(const std::string& text, std::size_t depth = kMaxJsonDepth) {
  try {
    parse_bounded_json(text, depth);
  } catch (const JsonLimitError& e) {
    return e.what();
  }
  return "";
}

TEST(BoundedJson, OrdinaryTextGivesWhatNlohmannsParserGives) {
  const std::string text = R"({"format":"panelbass.model/1","fs":3000,"params":{"a":[1,-2.5e-3,true,null,"x"],"b":{}},"u":18446744073709551615})";
  EXPECT_EQ(parse_bounded_json(text), nlohmann::json::parse(text));
  EXPECT_EQ(parse_bounded_json("[]"), nlohmann::json::array());
  EXPECT_EQ(parse_bounded_json("\"\\u00e9\""), "é");
}

TEST(BoundedJson, NestingIsRefusedOneLevelPastTheLimit) {
  EXPECT_EQ(parse_bounded_json(nested_arrays(64)), nlohmann::json::parse(nested_arrays(64)));
  EXPECT_EQ(message_of(nested_arrays(65)), "nesting deeper than 64 levels at [0][0][0][0][0][0][0][0]…");
  EXPECT_EQ(message_of(R"({"a":[1,{"b":{}}]})", 2), "nesting deeper than 2 levels at a[1]");
  // Half a million unterminated levels: refused at the limit, long before the end of the text.
  std::string deep;
  for (int k = 0; k < 500000; ++k) deep += R"({"a":)";
  EXPECT_EQ(message_of(deep), "nesting deeper than 64 levels at a.a.a.a.a.a.a.a…");
}

TEST(BoundedJson, ARepeatedKeyIsNamedWithItsObjectsPath) {
  EXPECT_EQ(message_of(R"({"kind":"a","kind":"b"})"), "duplicate key \"kind\" in the top-level object (a key may appear once in an object)");
  EXPECT_EQ(message_of(R"({"x":[0,{"k":1},{"k":1,"k":2}]})"), "duplicate key \"k\" in the object at x[2] (a key may appear once in an object)");
  // The same key in different objects is no repeat.
  EXPECT_NO_THROW(parse_bounded_json(R"({"k":{"k":{"k":1}},"j":[{"k":1},{"k":2}]})"));
}

TEST(BoundedJson, MalformedTextAndNumbersBeyondADoubleFailAsWithNlohmann) {
  EXPECT_THROW(parse_bounded_json("{\"a\":"), nlohmann::json::parse_error);
  EXPECT_THROW(parse_bounded_json("\"\xff\""), nlohmann::json::parse_error);
  EXPECT_THROW(parse_bounded_json("[1e999]"), nlohmann::json::out_of_range);
  EXPECT_THROW(parse_bounded_json("[1] x"), nlohmann::json::parse_error);
}

}  // namespace
}  // namespace panelbass::models

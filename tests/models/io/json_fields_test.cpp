// The validated JSON reader's unknown-key report, which both the model loaders (finish()) and the API's
// params reader (its own wording) use.

#include "models/io/json_fields.h"

#include <gtest/gtest.h>

#include "models/io/config_error.h"

namespace panelbass::models {
namespace {

TEST(JsonFields, TheFirstKeyNoAccessorAskedForIsReported) {
  const nlohmann::json value = {{"a", 1}, {"b", 2}, {"c", 3}};
  JsonFields fields(value, "model.params");
  fields.number("a");
  fields.member("c");
  EXPECT_EQ(fields.unknown_key(), "b");
  try {
    fields.finish();
    FAIL() << "finish() accepted an unknown key";
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "model.params.b: unknown key");
  }
  fields.member("b");
  EXPECT_EQ(fields.unknown_key(), std::nullopt);
  EXPECT_NO_THROW(fields.finish());
}

}  // namespace
}  // namespace panelbass::models

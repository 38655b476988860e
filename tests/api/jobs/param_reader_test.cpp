// The params reader on models::JsonFields: null counts as an empty object, defaults are filled in, an
// integral float is an integer, and the first field no accessor asked for is refused in the API's words.
// (Each kind's messages are pinned in job_kinds_test.cpp.)

#include "api/jobs/param_reader.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "tests/support/expect_error.h"

namespace panelbass::api {
namespace {

using nlohmann::json;
using testing_support::one_line_error;

TEST(ParamReader, NullIsAnEmptyObjectAndDefaultsAreFilledIn) {
  ParamReader r(nullptr, "params");
  EXPECT_EQ(r.integer("order", 8, 1, 40), 8);
  EXPECT_EQ(r.choice("method", "oe", {"arx", "oe"}), "oe");
  EXPECT_EQ(r.finish(), (json{{"order", 8}, {"method", "oe"}}));
}

TEST(ParamReader, AnIntegralFloatIsAnInteger) {
  ParamReader r({{"samples", 1e4}}, "params");
  EXPECT_EQ(r.integer("samples", 0, 200, 100000), 10000);
}

TEST(ParamReader, TheFirstUnaskedFieldIsRefusedByItsPath) {
  ParamReader r({{"b", 1}, {"a", 2}, {"c", 3}}, "params.excite");
  r.integer("b", 0, 0, 10);
  EXPECT_EQ(one_line_error<std::invalid_argument>([&] { r.finish(); }), "params.excite.a: unknown field");
}

TEST(ParamReader, AnythingButAnObjectOrNullIsRefused) {
  EXPECT_EQ(one_line_error<std::invalid_argument>([] { ParamReader r(json::array(), "params"); }),
            "params: expected an object, got array");
}

TEST(ParamReader, AnIntervalPrintsItsOpenAndClosedEnds) {
  EXPECT_EQ((Interval{0.0, 1.0, true, false}).text(), "(0, 1]");
  EXPECT_EQ((Interval{0.0, 1e12, false, false}).text(), "[0, 1e+12]");
  EXPECT_FALSE((Interval{0.0, 1.0, true, false}).contains(0.0));
  EXPECT_TRUE((Interval{0.0, 1.0, true, false}).contains(1.0));
}

}  // namespace
}  // namespace panelbass::api

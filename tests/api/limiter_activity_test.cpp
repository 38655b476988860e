// Limiter activity in GET /api/status and /metrics, through the real server: the band-pass alone on the
// engine's program (uniform noise of peak 0.2, well inside the limiter's knee of 0.8) asks nothing of the
// limiter; a controller with a gain of 6 to 8 asks for more than full scale, which the status says
// (needs_more_drive, the last second's fractions, the peak asked for above 1 while the drive stays below it),
// and which passes once the controller is gone.
#include <gtest/gtest.h>

#include <regex>
#include <string>

#include "tests/api/server_fixture.h"

namespace panelbass::api {
namespace {

using namespace api_testing;

TEST_F(ServerTest, TheStatusSaysWhenTheProgramNeedsMoreDriveThanTheChainAllows) {
  start();
  const nlohmann::json quiet = wait_status([](const nlohmann::json& s) { return s["metrics"]["limiter_window_s"] >= 0.5; });
  const nlohmann::json& q = quiet["metrics"];
  ASSERT_GE(q["limiter_window_s"].get<double>(), 0.5) << quiet;
  EXPECT_EQ(q["needs_more_drive"], false) << q;
  EXPECT_EQ(q["limited_fraction"], 0.0) << q;
  EXPECT_EQ(q["over_range_fraction"], 0.0) << q;
  EXPECT_EQ(q["limited_samples"], 0) << q;
  EXPECT_LT(q["peak_demand"].get<double>(), 0.8) << q;
  EXPECT_GT(q["peak_demand"].get<double>(), 0.0) << q;

  // u* = u + 7·u(k−1): a gain of 6 to 8 on band-passed noise of peak 0.2 asks for more than full scale often,
  // but never for 100 ms on end (no fault).
  const std::string loud = upload(lq_gain_controller(7.0));
  ASSERT_EQ(post("/api/models/" + loud + "/activate", std::string()).status, 200);
  const nlohmann::json busy = wait_status([](const nlohmann::json& s) { return s["metrics"]["needs_more_drive"] == true; });
  const nlohmann::json& b = busy["metrics"];
  ASSERT_EQ(b["needs_more_drive"], true) << busy;
  EXPECT_GT(b["over_range_fraction"].get<double>(), 0.0) << b;
  EXPECT_GE(b["limited_fraction"].get<double>(), b["over_range_fraction"].get<double>()) << b;
  EXPECT_LE(b["limited_fraction"].get<double>(), 1.0) << b;
  EXPECT_GT(b["over_range_samples"].get<double>(), 0.0) << b;
  EXPECT_GE(b["limited_samples"].get<double>(), b["over_range_samples"].get<double>()) << b;
  EXPECT_GT(b["peak_demand"].get<double>(), 1.0) << b;
  EXPECT_LT(b["peak_drive"].get<double>(), 1.0) << b;
  EXPECT_EQ(b["faults"], 0) << b;

  // /metrics carries the counters.
  const std::string metrics = get("/metrics").text;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(metrics, m, std::regex(R"(\npanelbass_over_range_samples_total (\d+)\n)"))) << metrics;
  EXPECT_GE(std::stod(m[1]), b["over_range_samples"].get<double>());
  ASSERT_TRUE(std::regex_search(metrics, m, std::regex(R"(\npanelbass_peak_demand ([0-9.e+-]+)\n)"))) << metrics;
  EXPECT_GT(std::stod(m[1]), 1.0);

  // Without the controller, the last second's activity goes back to none (the counters keep their totals).
  ASSERT_EQ(patch("/api/config", R"({"feedforward":{"model":null}})").status, 200);
  const nlohmann::json calm = wait_status([](const nlohmann::json& s) { return s["metrics"]["needs_more_drive"] == false; });
  EXPECT_EQ(calm["metrics"]["needs_more_drive"], false) << calm;
  EXPECT_EQ(calm["metrics"]["over_range_fraction"], 0.0) << calm;
  EXPECT_GE(calm["metrics"]["over_range_samples"].get<double>(), b["over_range_samples"].get<double>());
}

}  // namespace
}  // namespace panelbass::api

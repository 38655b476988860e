// The tune job over HTTP on the virtual transducer: measure, fit from the current, mirror filter, verify at equal
// output level, and the filter activated only when verify shows it helps (and the request did not say otherwise).

#include <gtest/gtest.h>

#include "models/plant/plant_config.h"
#include "tests/api/server_fixture.h"

namespace panelbass::api::api_testing {
namespace {

using namespace std::chrono_literals;

// A short tune: one probe, one level (the defaults play nine).
nlohmann::json short_tune(bool with_activate, bool activate) {
  nlohmann::json body = {{"kind", "tune"},
                         {"params", {{"samples", 12000}, {"frequencies", {80}}, {"levels", {0.2}}}}};
  if (with_activate) body["activate"] = activate;
  return body;
}

TEST_F(ServerTest, TuneKeepsAndActivatesTheMirrorFilterOnlyWhereVerifyShowsItCuts) {
  ServerOptions o = options(dir_ / "store");
  o.engine.plant = models::without_sensor_noise(o.engine.plant);  // THD read to the harmonics, not the noise
  start(o);
  const Reply submitted = post("/api/jobs", short_tune(false, false));
  ASSERT_EQ(submitted.status, 202) << submitted.text;
  const nlohmann::json job = wait_job(submitted.body["id"], 180s);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  const nlohmann::json& r = job["result"];
  ASSERT_EQ(r["steps"].size(), 5u) << r.dump();
  const nlohmann::json& point = r["verify"]["points"][0];
  ASSERT_TRUE(point["reachable"].get<bool>()) << point.dump();
  // equal output: the transducer alone was driven to the chain's sensor fundamental within 0.1 dB
  EXPECT_NEAR(20.0 * std::log10(point["plant_output_level"].get<double>() / point["output_level"].get<double>()), 0.0, 0.1);
  // the cut is the THDs' ratio in dB, positive for less distortion
  const double cut = point["thd_cut_db"].get<double>();
  EXPECT_NEAR(cut, 20.0 * std::log10(point["plant"]["thd_pct"].get<double>() / point["chain"]["thd_pct"].get<double>()), 1e-9);
  EXPECT_EQ(r["keep"].get<bool>(), cut >= 3.0) << r["decision"];
  ASSERT_TRUE(r["keep"].get<bool>()) << r["decision"];  // panel-exciter's 80 Hz distortion is cut by its mirror filter
  EXPECT_EQ(r["model_id"], r["mirror_model_id"]);
  EXPECT_EQ(job["activated"], (nlohmann::json{{"slot", "feedforward"}, {"id", r["model_id"]}}));
  EXPECT_EQ(get("/api/status").body["active_models"]["feedforward"], r["model_id"]);
  EXPECT_EQ(get("/api/models/" + r["model_id"].get<std::string>()).body["kind"], "mirror_filter");
  EXPECT_EQ(r["plots"]["thd_vs_level_80"]["level"].size(), 1u);

  // Told not to activate: the filter is stored, the slot keeps what it had.
  const Reply quiet = post("/api/jobs", short_tune(true, false));
  ASSERT_EQ(quiet.status, 202) << quiet.text;
  const nlohmann::json second = wait_job(quiet.body["id"], 180s);
  ASSERT_EQ(second["state"], "succeeded") << second.dump();
  EXPECT_FALSE(second.contains("activated")) << second.dump();
  EXPECT_EQ(get("/api/status").body["active_models"]["feedforward"], r["model_id"]);
  EXPECT_NE(get("/api/models/" + second["result"]["mirror_model_id"].get<std::string>()).status, 404);
}

TEST_F(ServerTest, TuneParamsOutOfRangeAreRefusedBeforeAnythingPlays) {
  start();
  const Reply amplitude = post("/api/jobs", nlohmann::json{{"kind", "tune"}, {"params", {{"amplitude", 1.5}}}});
  EXPECT_EQ(amplitude.status, 400);
  EXPECT_NE(amplitude.text.find("params.amplitude"), std::string::npos) << amplitude.text;
  const Reply probe = post("/api/jobs", nlohmann::json{{"kind", "tune"}, {"params", {{"frequencies", {1000}}}}});
  EXPECT_EQ(probe.status, 400);
  EXPECT_NE(probe.text.find("params.frequencies"), std::string::npos) << probe.text;
  const Reply sensor = post("/api/jobs", nlohmann::json{{"kind", "tune"}, {"params", {{"sensor_kind", "laser"}}}});
  EXPECT_EQ(sensor.status, 400);
  EXPECT_NE(sensor.text.find("params.sensor_kind"), std::string::npos) << sensor.text;
  EXPECT_EQ(get("/api/jobs").body["jobs"].size(), 0u);
}

}  // namespace
}  // namespace panelbass::api::api_testing

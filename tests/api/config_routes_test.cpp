// PUT and PATCH /api/config through the real server: a PUT takes the whole settings object (a field left out
// is a 400 naming it, and nothing changes: a controller is never switched off by omission), a PATCH a part;
// a change of fs, block or history is a 409 whatever else the settings hold (ROUTES.md "Engine").
#include <gtest/gtest.h>

#include <string>

#include "tests/api/server_fixture.h"

namespace panelbass::api {
namespace {

using namespace api_testing;

TEST_F(ServerTest, APutWithAFieldLeftOutIsRefusedNamingItAndTheControllerKeepsPlaying) {
  start();
  const std::string id = upload(lq_gain_controller(0.5));
  ASSERT_EQ(post("/api/models/" + id + "/activate", std::string()).status, 200);
  const nlohmann::json before = get("/api/config").body;
  ASSERT_EQ(before["feedforward"]["model"], id);

  // Only the band-pass (what switched the controller off before): refused, naming a missing field.
  const Reply partial = put("/api/config", nlohmann::json{{"band_pass", before["band_pass"]}});
  EXPECT_EQ(partial.status, 400) << partial.text;
  EXPECT_NE(error_message(partial).find(": missing (PUT /api/config takes the whole settings object"), std::string::npos)
      << partial.text;
  // Each field of the whole object, left out in turn, is named.
  for (const std::string key : {"feedforward.model", "feedback.source", "limiter.knee", "band_pass.order", "crossfade_ms"}) {
    nlohmann::json whole = before;
    const std::size_t dot = key.find('.');
    if (dot == std::string::npos) {
      whole.erase(key);
    } else {
      whole[key.substr(0, dot)].erase(key.substr(dot + 1));
    }
    const Reply r = put("/api/config", whole);
    EXPECT_EQ(r.status, 400) << key << ": " << r.text;
    EXPECT_NE(error_message(r).find("config." + key + ": missing"), std::string::npos) << r.text;
  }
  EXPECT_EQ(get("/api/config").body, before);
  EXPECT_EQ(get("/api/status").body["active_models"]["feedforward"], id);

  // The whole object without fs, block and history is complete.
  nlohmann::json whole = before;
  for (const char* key : {"fs", "block", "history"}) whole.erase(key);
  whole["crossfade_ms"] = 30;
  const Reply replaced = put("/api/config", whole);
  ASSERT_EQ(replaced.status, 200) << replaced.text;
  EXPECT_EQ(replaced.body["config"]["crossfade_ms"], 30.0);
  EXPECT_EQ(replaced.body["config"]["feedforward"]["model"], id);
  // A PATCH stays partial.
  const Reply patched = patch("/api/config", R"({"band_pass":{"low_hz":25}})");
  ASSERT_EQ(patched.status, 200) << patched.text;
  EXPECT_EQ(patched.body["config"]["band_pass"]["low_hz"], 25.0);
  EXPECT_EQ(patched.body["config"]["feedforward"]["model"], id);
}

TEST_F(ServerTest, ARateBlockOrHistoryChangeIsAConflictEvenWhenTheActiveModelsRunAtTheOldRate) {
  start();
  const std::string id = upload(lq_gain_controller(0.5));
  ASSERT_EQ(post("/api/models/" + id + "/activate", std::string()).status, 200);
  const nlohmann::json before = get("/api/config").body;
  // At 2000 Hz the 1200 Hz band-pass corner and the 3000 Hz controller would not fit: still a 409 naming fs.
  const Reply rate = patch("/api/config", R"({"fs":2000})");
  EXPECT_EQ(rate.status, 409) << rate.text;
  EXPECT_EQ(rate.body["error"]["code"], "conflict");
  EXPECT_NE(error_message(rate).find("fs (3000 → 2000)"), std::string::npos) << rate.text;
  nlohmann::json whole = before;
  whole["block"] = 128;
  const Reply block = put("/api/config", whole);
  EXPECT_EQ(block.status, 409) << block.text;
  EXPECT_NE(error_message(block).find("block (64 → 128)"), std::string::npos) << block.text;
  EXPECT_EQ(patch("/api/config", R"({"history":1024})").status, 409);
  // The same values are no change at all.
  EXPECT_EQ(patch("/api/config", R"({"fs":3000,"block":64})").status, 200);
  EXPECT_EQ(get("/api/config").body, before);
}

}  // namespace
}  // namespace panelbass::api

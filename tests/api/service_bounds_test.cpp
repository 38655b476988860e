// What the service keeps bounded and refuses by name (issue #57), through the real server: the job queue (429
// with the count), the job list (paged, newest first), the store's size in the status, one server per store,
// the safety limiter's settings, JSON nesting and repeated keys, and a model's free-form meta.
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "api/atomic_file.h"
#include "models/linear/linear_model.h"
#include "tests/api/server_fixture.h"

namespace panelbass::api {
namespace {

using namespace api_testing;

const nlohmann::json kExcite = {{"kind", "excite"}, {"params", {{"samples", 1000}}}};

TEST_F(ServerTest, TheJobQueueRefusesMoreThanItsBoundWith429SayingHowMany) {
  ServerOptions o = options(dir_ / "store");
  o.max_queued_jobs = 3;
  start(std::move(o));
  std::atomic<bool> release{false};
  server_->jobs().submit("held", nlohmann::json::object(), job_held_until(release));
  ASSERT_TRUE(wait_status([](const nlohmann::json& s) { return s["jobs"]["running"] == 1; })["jobs"]["running"] == 1);
  for (int k = 0; k < 3; ++k) ASSERT_EQ(post("/api/jobs", kExcite).status, 202);
  const Reply full = post("/api/jobs", kExcite);
  EXPECT_EQ(full.status, 429) << full.text;
  EXPECT_EQ(full.body["error"]["code"], "too_many_jobs") << full.text;
  EXPECT_NE(error_message(full).find("3 jobs wait for a worker (at most 3)"), std::string::npos) << full.text;
  EXPECT_EQ(get("/api/status").body["jobs"]["queued"], 3);
  // A cancelled job frees its place.
  ASSERT_EQ(del("/api/jobs/j2").status, 200);
  EXPECT_EQ(post("/api/jobs", kExcite).status, 202);
  release = true;
}

TEST_F(ServerTest, TheJobListIsPagedNewestFirst) {
  start();
  for (int k = 0; k < 5; ++k) {
    server_->jobs().submit("quick", nlohmann::json::object(),
                           [](const nlohmann::json&, JobControl&) { return nlohmann::json::object(); });
  }
  const Reply first = get("/api/jobs?limit=2");
  ASSERT_EQ(first.status, 200) << first.text;
  EXPECT_EQ(first.body["total"], 5);
  ASSERT_EQ(first.body["jobs"].size(), 2u);
  EXPECT_EQ(first.body["jobs"][0]["id"], "j5");
  EXPECT_EQ(first.body["jobs"][1]["id"], "j4");
  const Reply last = get("/api/jobs?offset=4&limit=2");
  ASSERT_EQ(last.body["jobs"].size(), 1u);
  EXPECT_EQ(last.body["jobs"][0]["id"], "j1");
  EXPECT_EQ(get("/api/jobs").body["limit"], 100);
  EXPECT_EQ(get("/api/jobs?limit=x").status, 400);
}

TEST_F(ServerTest, TheStatusReportsTheStoresSizeOnDisk) {
  start();
  upload(lq_gain_controller(0.5));
  upload(lq_gain_controller(0.25));
  // The bytes of every file under the store, counted here independently.
  const auto on_disk = [this] {
    std::uintmax_t bytes = 0;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(dir_ / "store")) {
      if (entry.is_regular_file()) bytes += entry.file_size();
    }
    return bytes;
  };
  const std::uintmax_t expected = on_disk();
  const nlohmann::json status = wait_status([&](const nlohmann::json& s) { return s["store"]["bytes"] == expected; });
  EXPECT_EQ(status["store"]["bytes"], expected) << status["store"].dump();
  EXPECT_EQ(status["store"]["models"], 2);
  EXPECT_EQ(status["store"]["path"], (dir_ / "store").string());
}

TEST_F(ServerTest, ASecondServerOnTheSameStoreIsRefusedNamingTheStoreAndTheHolder) {
  start();
  try {
    Server second(options(dir_ / "store"));
    FAIL() << "a second server opened the store";
  } catch (const StoreError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find((dir_ / "store").string()), std::string::npos) << message;
    EXPECT_NE(message.find("pid " + std::to_string(::getpid())), std::string::npos) << message;
  }
  // The first is undisturbed; once it has stopped, the store is free.
  EXPECT_EQ(get("/api/health").status, 200);
  client_.reset();
  server_.reset();
  EXPECT_NO_THROW(Server third(options(dir_ / "store")));
}

TEST_F(ServerTest, TheSafetyLimiterCannotBeSetOutOfItsRange) {
  start();
  const Reply level = patch("/api/config", R"({"limiter":{"pinned_level":1e308}})");
  EXPECT_EQ(level.status, 400) << level.text;
  EXPECT_NE(error_message(level).find("pinned_level: must be within (0, 1]"), std::string::npos) << level.text;
  const Reply hold = patch("/api/config", R"({"limiter":{"max_pinned_ms":60000}})");
  EXPECT_EQ(hold.status, 400) << hold.text;
  EXPECT_NE(error_message(hold).find("max_pinned_ms: must be within [0, 1000]"), std::string::npos) << hold.text;
  EXPECT_EQ(get("/api/config").body["limiter"]["pinned_level"], 1.0);
  EXPECT_EQ(get("/api/config").body["limiter"]["max_pinned_ms"], 100.0);
  EXPECT_EQ(patch("/api/config", R"({"limiter":{"pinned_level":0.9,"max_pinned_ms":1000}})").status, 200);
}

TEST_F(ServerTest, DeepNestingRepeatedKeysAndAnOversizedMetaAreRefusedByName) {
  start();
  // 50 000 levels of {"a": (300 KB, unterminated): refused at the 65th, the server unhurt.
  std::string deep;
  for (int k = 0; k < 50000; ++k) deep += R"({"a":)";
  const Reply nested = post("/api/models", deep);
  EXPECT_EQ(nested.status, 400) << nested.text;
  EXPECT_NE(error_message(nested).find("nesting deeper than 64 levels"), std::string::npos) << nested.text;
  nlohmann::json model = models::linear_model_to_json(engine::testing::example_linear());
  std::string meta = "1";
  for (int k = 0; k < 100; ++k) meta = R"({"a":)" + meta + "}";
  model.erase("meta");
  std::string text = model.dump();
  text.insert(text.size() - 1, R"(,"meta":)" + meta);
  const Reply deep_meta = post("/api/models", text);
  EXPECT_EQ(deep_meta.status, 400) << deep_meta.text;
  EXPECT_NE(error_message(deep_meta).find("at meta.a.a.a"), std::string::npos) << deep_meta.text;
  // The last "kind" no longer wins silently.
  const Reply twice = post("/api/jobs", std::string(R"({"kind":"teleport","kind":"excite","params":{"samples":1000}})"));
  EXPECT_EQ(twice.status, 400) << twice.text;
  EXPECT_NE(error_message(twice).find("duplicate key \"kind\" in the top-level object"), std::string::npos) << twice.text;
  const Reply inner = patch("/api/config", R"({"band_pass":{"low_hz":30,"low_hz":31}})");
  EXPECT_NE(error_message(inner).find("duplicate key \"low_hz\" in the object at band_pass"), std::string::npos) << inner.text;
  // Free-form notes beyond 64 KiB.
  model["meta"] = {{"note", std::string(70000, 'x')}};
  const Reply big = post("/api/models", model);
  EXPECT_EQ(big.status, 422) << big.text;
  EXPECT_NE(error_message(big).find("model.meta:"), std::string::npos) << big.text;
  EXPECT_EQ(get("/api/models").body["models"].size(), 0u);
  EXPECT_EQ(get("/api/health").status, 200);
}

TEST_F(ServerTest, AStoredFileNestedDeeperThanTheLimitIsSkippedAtStartUp) {
  start();
  const std::string id = upload(lq_gain_controller(0.5));
  client_.reset();
  server_.reset();
  // A job record whose result nests 10 000 levels (as a store filled before the limit could hold).
  std::string deep = "1";
  for (int k = 0; k < 10000; ++k) deep = "[" + deep + "]";
  std::ofstream(dir_ / "store" / "jobs" / "j7.json")
      << R"({"format":"panelbass.job/1","id":"j7","kind":"excite","state":"succeeded","result":)" << deep << "}";
  start();
  EXPECT_EQ(get("/api/jobs/j7").status, 404);
  EXPECT_EQ(get("/api/models/" + id).status, 200);
  bool warned = false;
  for (const std::string& line : log_lines()) {
    warned = warned || (line.find("j7.json") != std::string::npos && line.find("nesting deeper than 64") != std::string::npos);
  }
  EXPECT_TRUE(warned);
}

}  // namespace
}  // namespace panelbass::api

#include "api/model_store.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <complex>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

#include "api/job_queue.h"
#include "models/linear/linear_model.h"
#include "models/linear/transfer_function.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// A linear model file with one real pole at `pole` (stable for |pole| < 1) at 3000 Hz.
json linear_model(double pole, double gain = 0.1) {
  models::LinearModel m;
  m.tf.a = Eigen::VectorXd::Constant(1, -pole);
  m.tf.b = Eigen::VectorXd::Constant(1, gain);
  m.tf.nk = 1;
  m.fs = 3000.0;
  return models::linear_model_to_json(m);
}

// The store id written out from its definition: "m" + the low 48 bits of the 64-bit FNV-1a hash of the
// model's compact JSON text, as 12 lower-case hex digits.
std::string expected_id(const json& model) {
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char c : model.dump()) {
    h ^= c;
    h *= 1099511628211ull;
  }
  h &= 0xffffffffffffull;
  static const char* const digits = "0123456789abcdef";
  std::string id = "m";
  for (int shift = 44; shift >= 0; shift -= 4) id += digits[(h >> shift) & 0xf];
  return id;
}

class ModelStoreTest : public testing_support::ScratchDirectoryTest {
 protected:
  ModelStore open() {
    return ModelStore(dir_, [this](const std::string& message) { warnings_.push_back(message); });
  }
  // The warnings that name `name`.
  int warnings_naming(const std::string& name) const {
    int n = 0;
    for (const std::string& w : warnings_) n += w.find(name) != std::string::npos ? 1 : 0;
    return n;
  }
  std::vector<std::string> warnings_;
};

TEST(ModelStoreIds, ValidIdsAreShortAndPlain) {
  EXPECT_TRUE(is_valid_id("m0123456789ab"));
  EXPECT_TRUE(is_valid_id("j17"));
  EXPECT_TRUE(is_valid_id("A_b-9"));
  EXPECT_TRUE(is_valid_id(std::string(64, 'x')));
  EXPECT_FALSE(is_valid_id(""));
  EXPECT_FALSE(is_valid_id(std::string(65, 'x')));
  EXPECT_FALSE(is_valid_id("../x"));
  EXPECT_FALSE(is_valid_id("a/b"));
  EXPECT_FALSE(is_valid_id("a.b"));
  EXPECT_FALSE(is_valid_id("a b"));
  EXPECT_FALSE(is_valid_id(std::string("a\0b", 3)));
}

TEST(ModelStoreIds, TheIdIsTheContentHash) {
  const json model = linear_model(0.5);
  EXPECT_EQ(model_store_id(model), expected_id(model));
  EXPECT_TRUE(std::regex_match(model_store_id(model), std::regex("m[0-9a-f]{12}")));
  EXPECT_NE(model_store_id(model), model_store_id(linear_model(0.6)));
}

TEST_F(ModelStoreTest, PutFindListRemove) {
  ModelStore store = open();
  const json first = linear_model(0.5);
  const json second = linear_model(0.7);
  bool created = false;
  const StoredModel a = store.put(first, "linear", 3000.0, "first", "upload", &created);
  EXPECT_TRUE(created);
  EXPECT_EQ(a.id, expected_id(first));
  EXPECT_EQ(a.kind, "linear");
  EXPECT_EQ(a.name, "first");
  EXPECT_EQ(a.source, "upload");
  EXPECT_TRUE(std::regex_match(a.created, std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)"))) << a.created;
  const StoredModel b = store.put(second, "linear", 3000.0, "", "j4", &created);
  EXPECT_TRUE(created);

  ASSERT_TRUE(store.find(a.id).has_value());
  EXPECT_EQ(store.find(a.id)->name, "first");
  EXPECT_EQ(*store.model(b.id), second);
  const std::vector<StoredModel> all = store.list();
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].id, a.id);
  EXPECT_EQ(all[1].id, b.id);
  EXPECT_TRUE(std::filesystem::is_regular_file(dir_ / "models" / (a.id + ".json")));
  EXPECT_EQ(stored_model_to_json(a),
            json({{"id", a.id}, {"kind", "linear"}, {"fs", 3000.0}, {"name", "first"}, {"created", a.created},
                  {"source", "upload"}}));

  EXPECT_TRUE(store.remove(a.id));
  EXPECT_FALSE(store.remove(a.id));
  EXPECT_FALSE(store.find(a.id).has_value());
  EXPECT_FALSE(store.model(a.id).has_value());
  EXPECT_FALSE(std::filesystem::exists(dir_ / "models" / (a.id + ".json")));
  ASSERT_EQ(store.list().size(), 1u);
  EXPECT_EQ(store.list()[0].id, b.id);
}

TEST_F(ModelStoreTest, TheSameModelTwiceIsStoredOnceAndANewNameRenamesIt) {
  ModelStore store = open();
  const json model = linear_model(0.5);
  bool created = true;
  const StoredModel first = store.put(model, "linear", 3000.0, "one", "upload", &created);
  EXPECT_TRUE(created);
  const StoredModel again = store.put(json::parse(model.dump()), "linear", 3000.0, "two", "j1", &created);
  EXPECT_FALSE(created);
  EXPECT_EQ(again.id, first.id);
  EXPECT_EQ(again.name, "two");
  EXPECT_EQ(again.source, "upload");  // only the name changes
  EXPECT_EQ(again.created, first.created);
  EXPECT_EQ(store.list().size(), 1u);
  // Without a name it keeps the one it has.
  EXPECT_EQ(store.put(model, "linear", 3000.0, "", "upload", &created).name, "two");
  // The new name is on disk.
  const ModelStore reopened = open();
  ASSERT_EQ(reopened.list().size(), 1u);
  EXPECT_EQ(reopened.list()[0].name, "two");
  EXPECT_TRUE(warnings_.empty());
}

TEST_F(ModelStoreTest, AReopenedStoreSeesModelsAndJobs) {
  StoredModel a, b;
  JobRecord job;
  job.id = "j3";
  job.kind = "identify-linear";
  job.state = JobState::succeeded;
  job.progress = 1.0;
  job.params = {{"order", 4}};
  job.result = {{"model_id", "m0123456789ab"}};
  job.created = "2026-11-22T09:00:00Z";
  job.extra = {{"activated", {{"slot", "feedforward"}, {"id", "m0123456789ab"}}}};
  {
    ModelStore store = open();
    a = store.put(linear_model(0.5), "linear", 3000.0, "a", "upload");
    b = store.put(linear_model(0.6), "linear", 3000.0, "b", "j3");
    store.put_job("j3", job_to_json(job, true));
  }
  const json on_disk = json::parse(testing_support::ScratchDirectoryTest::text_of(dir_ / "jobs" / "j3.json"));
  EXPECT_EQ(on_disk["format"], "panelbass.job/1");

  ModelStore reopened = open();
  EXPECT_TRUE(warnings_.empty()) << warnings_.front();
  const std::vector<StoredModel> all = reopened.list();
  ASSERT_EQ(all.size(), 2u);
  for (const StoredModel& before : {a, b}) {
    const std::optional<StoredModel> after = reopened.find(before.id);
    ASSERT_TRUE(after.has_value());
    EXPECT_EQ(after->kind, before.kind);
    EXPECT_EQ(after->fs, before.fs);
    EXPECT_EQ(after->name, before.name);
    EXPECT_EQ(after->created, before.created);
    EXPECT_EQ(after->source, before.source);
  }
  EXPECT_EQ(*reopened.model(a.id), linear_model(0.5));

  const std::vector<json> jobs = reopened.jobs();
  ASSERT_EQ(jobs.size(), 1u);
  EXPECT_FALSE(jobs[0].contains("format"));
  const JobRecord back = job_from_json(jobs[0]);
  EXPECT_EQ(back.id, "j3");
  EXPECT_EQ(back.state, JobState::succeeded);
  EXPECT_EQ(back.params, job.params);
  EXPECT_EQ(back.result, job.result);
  EXPECT_EQ(back.extra, job.extra);
}

TEST_F(ModelStoreTest, JobsComeBackInOrderOfTheirNumber) {
  ModelStore store = open();
  for (const char* id : {"j10", "j2", "j1"}) {
    JobRecord job;
    job.id = id;
    job.kind = "analyze";
    job.state = JobState::failed;
    job.error = "x";
    store.put_job(id, job_to_json(job, true));
  }
  std::vector<std::string> ids;
  for (const json& record : open().jobs()) ids.push_back(record["id"]);
  EXPECT_EQ(ids, (std::vector<std::string>{"j1", "j2", "j10"}));
}

TEST_F(ModelStoreTest, BadFilesAreSkippedWithAWarningNamingThemAndTheRestIsLoaded) {
  std::string good_id, good_text;
  {
    ModelStore store = open();
    good_id = store.put(linear_model(0.5), "linear", 3000.0, "good", "upload").id;
    JobRecord job;
    job.id = "j1";
    job.kind = "excite";
    job.state = JobState::succeeded;
    store.put_job("j1", job_to_json(job, true));
  }
  good_text = text_of(dir_ / "models" / (good_id + ".json"));
  json good = json::parse(good_text);

  // truncated JSON
  file("models/m111111111111.json", good_text.substr(0, good_text.size() / 2));
  // another program's file
  json foreign = good;
  foreign["format"] = "someone-else/1";
  foreign["id"] = "m222222222222";
  file("models/m222222222222.json", foreign.dump());
  // a copy under another name: its id differs from its file name
  file("models/m333333333333.json", good_text);
  // a model that fails validation (pole 1.2), under its own content id
  json unstable = good;
  unstable["model"] = linear_model(1.2);
  unstable["id"] = model_store_id(unstable["model"]);
  const std::string unstable_name = unstable["id"].get<std::string>() + ".json";
  file("models/" + unstable_name, unstable.dump());
  // an edited model: the id no longer matches its content
  json edited = good;
  edited["model"] = linear_model(0.4);
  edited["id"] = "m444444444444";
  file("models/m444444444444.json", edited.dump());
  // not a .json file, and the left-over of a write that was interrupted
  file("models/notes.txt", "hello");
  file("models/." + good_id + ".json.tmp-99-1", "{\"partial");
  // a job file that does not parse, and one whose record is not a job
  file("jobs/j2.json", "{");
  file("jobs/j3.json", json({{"format", "panelbass.job/1"}, {"id", "j3"}, {"state", "exploded"}}).dump());

  ModelStore store = open();
  ASSERT_EQ(store.list().size(), 1u);
  EXPECT_EQ(store.list()[0].id, good_id);
  EXPECT_EQ(store.jobs().size(), 1u);
  for (const std::string& name : {std::string("m111111111111.json"), std::string("m222222222222.json"),
                                  std::string("m333333333333.json"), unstable_name,
                                  std::string("m444444444444.json"), std::string("notes.txt"),
                                  std::string("j2.json"), std::string("j3.json")}) {
    EXPECT_EQ(warnings_naming(name), 1) << name;
  }
  EXPECT_EQ(warnings_naming(".tmp-99-1"), 1);
  EXPECT_FALSE(std::filesystem::exists(dir_ / "models" / ("." + good_id + ".json.tmp-99-1")));
  // the bad files themselves are left for a person to look at
  EXPECT_TRUE(std::filesystem::exists(dir_ / "models" / "m111111111111.json"));
}

TEST_F(ModelStoreTest, AFailedWriteChangesNothing) {
  ModelStore store = open();
  std::filesystem::remove_all(dir_ / "models");
  EXPECT_THROW(store.put(linear_model(0.5), "linear", 3000.0, "", "upload"), StoreError);
  EXPECT_TRUE(store.list().empty());
  EXPECT_FALSE(store.find(model_store_id(linear_model(0.5))).has_value());
}

TEST_F(ModelStoreTest, JobsWithAnInvalidIdAreRefused) {
  ModelStore store = open();
  EXPECT_THROW(store.put_job("../j1", json::object()), StoreError);
  EXPECT_TRUE(store.jobs().empty());
}

}  // namespace
}  // namespace panelbass::api

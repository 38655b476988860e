#include "api/job_queue.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace panelbass::api {
namespace {

using nlohmann::json;
using std::chrono::milliseconds;

// Long enough that a healthy queue never reaches it; a test that does fails instead of hanging.
constexpr milliseconds kPatience{4000};

// Work that reports progress until `release` is set (or the job is cancelled, when progress() throws).
JobWork hold_until(std::shared_ptr<std::atomic<bool>> release) {
  return [release](const json&, JobControl& control) -> json {
    while (!release->load()) {
      control.progress(0.5, "holding");
      std::this_thread::sleep_for(milliseconds(1));
    }
    return {{"released", true}};
  };
}

// Blocks until `id` has reported `state` (read from its event stream).
void await_state(const JobQueue& queue, const std::string& id, const std::string& state) {
  std::uint64_t after = 0;
  for (;;) {
    bool ended = false;
    const std::vector<JobEvent> events = queue.events_after(id, after, kPatience, &ended);
    ASSERT_FALSE(events.empty()) << "no event from " << id << " while waiting for " << state;
    for (const JobEvent& event : events) {
      if (event.type == "state" && event.data["state"] == state) return;
      after = event.sequence;
    }
    ASSERT_FALSE(ended) << id << " ended before reaching " << state;
  }
}

bool is_utc_time(const std::string& s) {
  return std::regex_match(s, std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)"));
}

TEST(JobQueue, ASucceededJobHasItsResult) {
  JobQueue queue(1);
  const std::string id = queue.submit("double", {{"x", 21}}, [](const json& params, JobControl& control) -> json {
    return {{"y", params["x"].get<int>() * 2}, {"job", control.job_id()}};
  });
  EXPECT_EQ(id, "j1");
  ASSERT_TRUE(queue.wait(id, kPatience));
  const JobRecord job = *queue.get(id);
  EXPECT_EQ(job.kind, "double");
  EXPECT_EQ(job.state, JobState::succeeded);
  EXPECT_EQ(job.result, json({{"y", 42}, {"job", "j1"}}));
  EXPECT_EQ(job.params, json({{"x", 21}}));
  EXPECT_EQ(job.progress, 1.0);
  EXPECT_EQ(job.error, "");
  EXPECT_TRUE(is_utc_time(job.created)) << job.created;
  EXPECT_TRUE(is_utc_time(job.started)) << job.started;
  EXPECT_TRUE(is_utc_time(job.finished)) << job.finished;
  EXPECT_EQ(queue.submit("double", {{"x", 1}}, [](const json&, JobControl&) { return json(); }), "j2");
}

TEST(JobQueue, AResultsWarningsBecomeTheRecordsAndEveryJobShowsThem) {
  JobQueue queue(1);
  const std::string warned = queue.submit("w", json::object(), [](const json&, JobControl&) -> json {
    return {{"y", 1}, {"warnings", {"J = 100.3 % is no better than zero.", "try nk"}}};
  });
  const std::string clean = queue.submit("c", json::object(), [](const json&, JobControl&) -> json { return {{"y", 2}}; });
  ASSERT_TRUE(queue.wait(warned, kPatience));
  ASSERT_TRUE(queue.wait(clean, kPatience));
  const JobRecord job = *queue.get(warned);
  EXPECT_EQ(job.warnings, (std::vector<std::string>{"J = 100.3 % is no better than zero.", "try nk"}));
  EXPECT_EQ(job.result, json({{"y", 1}})) << "taken out of the result";
  const json shown = job_to_json(job, true);
  EXPECT_EQ(shown["warnings"], json({"J = 100.3 % is no better than zero.", "try nk"}));
  EXPECT_EQ(job_from_json(shown).warnings, job.warnings) << "a stored job keeps them";
  EXPECT_FALSE(job_from_json(shown).extra.contains("warnings"));
  EXPECT_EQ(job_to_json(*queue.get(clean), false)["warnings"], json::array()) << "present and empty when all is well";
  const std::vector<JobRecord> listed = queue.list();
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(job_to_json(listed[0], false)["warnings"].size(), 2u) << "the list shows them too";
  EXPECT_THROW(job_from_json({{"id", "j9"}, {"kind", "k"}, {"state", "succeeded"}, {"warnings", {1}}}), std::invalid_argument);
}

// The niceness of the calling thread (getpriority on its own thread id).
int this_thread_niceness() {
  errno = 0;
  return ::getpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)));
}

TEST(JobQueue, WorkRunsAtALowerPriorityThanTheAudioThreadCanHave) {
  // The worker lowers its own priority to niceness 10 so the audio thread (never niced) wins a core;
  // under a parent already niced beyond 10 it stays where it was, since no process may raise it back.
  const int ours = this_thread_niceness();
  JobQueue queue(1);
  const std::string id =
      queue.submit("niceness", json::object(), [](const json&, JobControl&) -> json { return this_thread_niceness(); });
  ASSERT_TRUE(queue.wait(id, kPatience));
  EXPECT_EQ(queue.get(id)->result.get<int>(), std::max(ours, 10));
  EXPECT_EQ(this_thread_niceness(), ours) << "the submitting thread is left alone";
}

TEST(JobQueue, AFailedJobKeepsItsMessage) {
  JobQueue queue(2);
  const std::string std_error = queue.submit("k", json::object(), [](const json&, JobControl&) -> json {
    throw std::runtime_error("params.order: too large for 100 samples");
  });
  const std::string other = queue.submit("k", json::object(), [](const json&, JobControl&) -> json { throw 42; });
  ASSERT_TRUE(queue.wait(std_error, kPatience));
  ASSERT_TRUE(queue.wait(other, kPatience));
  EXPECT_EQ(queue.get(std_error)->state, JobState::failed);
  EXPECT_EQ(queue.get(std_error)->error, "params.order: too large for 100 samples");
  EXPECT_TRUE(queue.get(std_error)->result.is_null());
  EXPECT_EQ(queue.get(other)->state, JobState::failed);
  EXPECT_EQ(queue.get(other)->error, "unknown error");
  EXPECT_EQ(queue.count(JobState::failed), 2u);
}

TEST(JobQueue, AQueuedJobIsCancelledAtOnceAndNeverRuns) {
  JobQueue queue(2);
  auto release = std::make_shared<std::atomic<bool>>(false);
  const std::string a = queue.submit("hold", {}, hold_until(release));
  const std::string b = queue.submit("hold", {}, hold_until(release));
  auto ran = std::make_shared<std::atomic<bool>>(false);
  const std::string c = queue.submit("never", {}, [ran](const json&, JobControl&) {
    ran->store(true);
    return json();
  });
  await_state(queue, a, "running");
  await_state(queue, b, "running");
  EXPECT_EQ(queue.count(JobState::queued), 1u);

  EXPECT_EQ(queue.cancel(c), JobState::queued);
  EXPECT_EQ(queue.get(c)->state, JobState::cancelled);
  EXPECT_EQ(queue.cancel(c), JobState::cancelled);  // left as it was
  EXPECT_EQ(queue.cancel("j99"), std::nullopt);

  release->store(true);
  ASSERT_TRUE(queue.wait(a, kPatience));
  ASSERT_TRUE(queue.wait(b, kPatience));
  EXPECT_EQ(queue.get(a)->state, JobState::succeeded);
  EXPECT_EQ(queue.get(b)->state, JobState::succeeded);
  EXPECT_FALSE(ran->load());
}

TEST(JobQueue, ARunningJobIsCancelledAtItsNextProgressReport) {
  JobQueue queue(1);
  auto never = std::make_shared<std::atomic<bool>>(false);
  const std::string id = queue.submit("hold", {}, hold_until(never));
  await_state(queue, id, "running");
  EXPECT_EQ(queue.cancel(id), JobState::running);
  ASSERT_TRUE(queue.wait(id, kPatience));
  const JobRecord job = *queue.get(id);
  EXPECT_EQ(job.state, JobState::cancelled);
  EXPECT_TRUE(job.result.is_null());
  EXPECT_EQ(job.error, "");
}

TEST(JobQueue, WorkThatPollsSeesTheCancellation) {
  JobQueue queue(1);
  const std::string id = queue.submit("poll", {}, [](const json&, JobControl& control) -> json {
    control.progress(0.1, "started");
    while (!control.cancelled()) std::this_thread::sleep_for(milliseconds(1));
    throw JobCancelled{};
  });
  std::uint64_t after = 0;
  for (bool seen = false; !seen;) {  // wait for its progress report: it is then inside the loop
    const auto events = queue.events_after(id, after, kPatience);
    ASSERT_FALSE(events.empty());
    for (const JobEvent& e : events) seen = seen || e.type == "progress";
    after = events.back().sequence;
  }
  queue.cancel(id);
  ASSERT_TRUE(queue.wait(id, kPatience));
  EXPECT_EQ(queue.get(id)->state, JobState::cancelled);
}

TEST(JobQueue, EventsComeInOrderAndEndWithTheFinalState) {
  JobQueue queue(1);
  const std::string id = queue.submit("steps", {}, [](const json&, JobControl& control) {
    control.progress(0.25, "first");
    control.progress(7.0, "clamped");
    control.progress(0.75, "last");
    return json{{"done", true}};
  });
  // Followed as a client does, from sequence 0 until the stream says it ended.
  std::vector<JobEvent> events;
  bool ended = false;
  while (!ended) {
    const auto more = queue.events_after(id, events.empty() ? 0 : events.back().sequence, kPatience, &ended);
    ASSERT_TRUE(!more.empty() || ended);
    events.insert(events.end(), more.begin(), more.end());
  }
  const std::vector<std::pair<std::string, json>> expected = {
      {"state", {{"state", "queued"}}},
      {"state", {{"state", "running"}}},
      {"progress", {{"progress", 0.25}, {"message", "first"}}},
      {"progress", {{"progress", 1.0}, {"message", "clamped"}}},
      {"progress", {{"progress", 0.75}, {"message", "last"}}},
      {"state", {{"state", "succeeded"}}},
  };
  ASSERT_EQ(events.size(), expected.size());
  for (std::size_t i = 0; i < events.size(); ++i) {
    EXPECT_EQ(events[i].sequence, i + 1);
    EXPECT_EQ(events[i].type, expected[i].first);
    EXPECT_EQ(events[i].data, expected[i].second);
  }
  // Nothing follows the end: an immediate, empty answer that says so.
  ended = false;
  EXPECT_TRUE(queue.events_after(id, events.back().sequence, kPatience, &ended).empty());
  EXPECT_TRUE(ended);
}

TEST(JobQueue, AFailedJobsFinalEventCarriesTheError) {
  JobQueue queue(1);
  const std::string id =
      queue.submit("k", {}, [](const json&, JobControl&) -> json { throw std::invalid_argument("bad"); });
  ASSERT_TRUE(queue.wait(id, kPatience));
  const auto events = queue.events_after(id, 0, milliseconds(0));
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().data, json({{"state", "failed"}, {"error", "bad"}}));
}

TEST(JobQueue, ALongJobKeepsItsStateEventsAndItsLastProgress) {
  JobQueue queue(1);
  const std::string id = queue.submit("chatty", {}, [](const json&, JobControl& control) {
    for (int i = 1; i <= 5000; ++i) control.progress(i / 5000.0, "step " + std::to_string(i));
    return json();
  });
  ASSERT_TRUE(queue.wait(id, kPatience));
  const auto events = queue.events_after(id, 0, milliseconds(0));
  ASSERT_GE(events.size(), 4u);
  EXPECT_LE(events.size(), 1100u);
  EXPECT_EQ(events[0].data, json({{"state", "queued"}}));
  EXPECT_EQ(events[1].data, json({{"state", "running"}}));
  EXPECT_EQ(events[events.size() - 2].data, json({{"progress", 1.0}, {"message", "step 5000"}}));
  EXPECT_EQ(events.back().data, json({{"state", "succeeded"}}));
  EXPECT_EQ(events.back().sequence, 5003u);
  for (std::size_t i = 1; i < events.size(); ++i) EXPECT_LT(events[i - 1].sequence, events[i].sequence);
}

TEST(JobQueue, EventsAfterGivesNothingWhenNothingHappens) {
  JobQueue queue(1);
  auto release = std::make_shared<std::atomic<bool>>(false);
  const std::string id = queue.submit("quiet", {}, [release](const json&, JobControl&) {
    while (!release->load()) std::this_thread::sleep_for(milliseconds(1));
    return json();
  });
  await_state(queue, id, "running");
  bool ended = true;
  EXPECT_TRUE(queue.events_after(id, 2, milliseconds(20), &ended).empty());
  EXPECT_FALSE(ended);
  EXPECT_FALSE(queue.wait(id, milliseconds(20)));
  ended = false;
  EXPECT_TRUE(queue.events_after("j404", 0, milliseconds(20), &ended).empty());
  EXPECT_TRUE(ended);
  release->store(true);
  EXPECT_TRUE(queue.wait(id, kPatience));
}

TEST(JobQueue, RestoredJobsComeBackEndedAndIdsContinue) {
  JobQueue queue(1);
  JobRecord running;
  running.id = "j3";
  running.kind = "identify-narx";
  running.state = JobState::running;
  running.progress = 0.4;
  JobRecord done;
  done.id = "j7";
  done.kind = "excite";
  done.state = JobState::succeeded;
  done.result = {{"fs", 3000}};
  done.finished = "2026-11-22T08:00:00Z";
  queue.restore(done);
  queue.restore(running);
  JobRecord duplicate = done;
  duplicate.kind = "other";
  queue.restore(duplicate);

  EXPECT_EQ(queue.get("j3")->state, JobState::failed);
  EXPECT_EQ(queue.get("j3")->error, "interrupted by a restart");
  EXPECT_EQ(queue.get("j7")->kind, "excite");
  EXPECT_EQ(queue.get("j7")->result, done.result);
  EXPECT_EQ(queue.get("j7")->finished, done.finished);
  EXPECT_TRUE(queue.wait("j3", milliseconds(0)));

  const std::string next = queue.submit("k", {}, [](const json&, JobControl&) { return json(); });
  EXPECT_EQ(next, "j8");
  std::vector<std::string> ids;
  for (const JobRecord& job : queue.list()) ids.push_back(job.id);
  EXPECT_EQ(ids, (std::vector<std::string>{"j3", "j7", "j8"}));

  bool ended = false;
  const auto events = queue.events_after("j3", 0, milliseconds(0), &ended);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].data, json({{"state", "failed"}, {"error", "interrupted by a restart"}}));
  EXPECT_TRUE(ended);
}

TEST(JobQueue, OnFinishedSeesTheEndedRecordBeforeAnyoneElse) {
  std::mutex mutex;
  std::vector<std::pair<std::string, JobState>> seen;
  JobQueue queue(1, [&](JobRecord& job) {
    const std::lock_guard lock(mutex);
    seen.emplace_back(job.id, job.state);
    if (job.state == JobState::succeeded) job.extra["activated"] = {{"slot", "feedforward"}, {"id", "m1"}};
  });
  const std::string id = queue.submit("k", {}, [](const json&, JobControl&) { return json{{"model_id", "m1"}}; });
  ASSERT_TRUE(queue.wait(id, kPatience));
  // wait() returned, so the extra written by on_finished is already there.
  EXPECT_EQ(queue.get(id)->extra["activated"]["slot"], "feedforward");
  EXPECT_EQ(job_to_json(*queue.get(id), true)["activated"]["id"], "m1");
  const std::lock_guard lock(mutex);
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0], std::make_pair(id, JobState::succeeded));
}

TEST(JobQueue, AnOnFinishedThatThrowsFailsTheJob) {
  JobQueue queue(1, [](JobRecord& job) {
    if (job.kind == "activate") throw std::runtime_error("cannot activate: conflict");
  });
  const std::string id = queue.submit("activate", {}, [](const json&, JobControl&) { return json{{"ok", 1}}; });
  ASSERT_TRUE(queue.wait(id, kPatience));
  EXPECT_EQ(queue.get(id)->state, JobState::failed);
  EXPECT_EQ(queue.get(id)->error, "cannot activate: conflict");
  EXPECT_TRUE(queue.get(id)->result.is_null());
}

TEST(JobQueue, DestroyingTheQueueCancelsRunningAndWaitingJobs) {
  auto finished = std::make_shared<std::vector<std::pair<std::string, JobState>>>();
  auto mutex = std::make_shared<std::mutex>();
  std::string running, waiting;
  {
    JobQueue queue(1, [finished, mutex](JobRecord& job) {
      const std::lock_guard lock(*mutex);
      finished->emplace_back(job.id, job.state);
    });
    auto never = std::make_shared<std::atomic<bool>>(false);
    running = queue.submit("hold", {}, hold_until(never));
    waiting = queue.submit("hold", {}, hold_until(never));
    await_state(queue, running, "running");
  }
  // The destructor returned although the work would have run forever; both jobs were ended as cancelled.
  const std::lock_guard lock(*mutex);
  ASSERT_EQ(finished->size(), 2u);
  for (const auto& [id, state] : *finished) EXPECT_EQ(state, JobState::cancelled) << id;
}

TEST(JobRecordJson, TheSummaryAndTheDetails) {
  JobRecord job;
  job.id = "j5";
  job.kind = "design-lq";
  job.state = JobState::running;
  job.progress = 0.5;
  job.message = "riccati";
  job.params = {{"r", 1e-5}};
  job.created = "2026-11-22T09:00:00Z";
  job.started = "2026-11-22T09:00:01Z";
  job.extra = {{"activated", nullptr}, {"state", "must not replace the record's own"}};
  const json summary = job_to_json(job, false);
  EXPECT_EQ(summary, json({{"id", "j5"},
                           {"kind", "design-lq"},
                           {"state", "running"},
                           {"progress", 0.5},
                           {"message", "riccati"},
                           {"created", "2026-11-22T09:00:00Z"},
                           {"started", "2026-11-22T09:00:01Z"},
                           {"finished", nullptr},
                           {"error", nullptr},
                           {"warnings", json::array()}}));
  const json details = job_to_json(job, true);
  EXPECT_EQ(details["params"], job.params);
  EXPECT_TRUE(details["result"].is_null());
  EXPECT_TRUE(details.contains("activated"));
  EXPECT_EQ(details["state"], "running");

  const JobRecord back = job_from_json(details);
  EXPECT_EQ(back.id, job.id);
  EXPECT_EQ(back.kind, job.kind);
  EXPECT_EQ(back.state, job.state);
  EXPECT_EQ(back.progress, job.progress);
  EXPECT_EQ(back.message, job.message);
  EXPECT_EQ(back.params, job.params);
  EXPECT_EQ(back.created, job.created);
  EXPECT_EQ(back.started, job.started);
  EXPECT_EQ(back.finished, "");
  EXPECT_EQ(back.extra, json({{"activated", nullptr}}));
}

TEST(JobRecordJson, ErrorsNameTheField) {
  JobRecord job;
  job.id = "j1";
  job.kind = "excite";
  const json good = job_to_json(job, true);
  const auto message = [](const json& j) {
    try {
      job_from_json(j);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  json bad_state = good;
  bad_state["state"] = "paused";
  EXPECT_NE(message(bad_state).find("job.state"), std::string::npos);
  json no_id = good;
  no_id.erase("id");
  EXPECT_NE(message(no_id).find("job.id"), std::string::npos);
  json bad_progress = good;
  bad_progress["progress"] = "half";
  EXPECT_NE(message(bad_progress).find("job.progress"), std::string::npos);
  json bad_time = good;
  bad_time["finished"] = 12;
  EXPECT_NE(message(bad_time).find("job.finished"), std::string::npos);
  EXPECT_NE(message(json::array()).find("job"), std::string::npos);
}

TEST(JobQueue, OnlyTheNewestFinishedJobsKeepTheirResultsInMemory) {
  std::vector<std::string> persisted;
  JobQueue queue(1, [&persisted](JobRecord& job) { persisted.push_back(job.result.dump()); });
  const std::size_t extra = 5;
  std::vector<std::string> ids;
  for (std::size_t k = 0; k < JobQueue::kResultsKept + extra; ++k) {
    ids.push_back(queue.submit("echo", {{"k", k}}, [](const json& params, JobControl&) -> json {
      return {{"k", params["k"]}, {"padding", std::string(1000, 'x')}};
    }));
  }
  for (const std::string& id : ids) ASSERT_TRUE(queue.wait(id, kPatience));
  // Every result reached the owner before anything was dropped.
  ASSERT_EQ(persisted.size(), ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k) {
    EXPECT_NE(persisted[k].find("\"k\":" + std::to_string(k)), std::string::npos) << persisted[k];
    const JobRecord job = *queue.get(ids[k]);
    EXPECT_EQ(job.state, JobState::succeeded);
    if (k < extra) {
      EXPECT_TRUE(job.result_dropped) << ids[k];
      EXPECT_TRUE(job.result.is_null());
      // Its stream still ends with the final state.
      bool ended = false;
      const std::vector<JobEvent> events = queue.events_after(ids[k], 0, milliseconds(10), &ended);
      ASSERT_EQ(events.size(), 1u);
      EXPECT_EQ(events[0].data["state"], "succeeded");
      EXPECT_TRUE(ended);
    } else {
      EXPECT_FALSE(job.result_dropped) << ids[k];
      EXPECT_EQ(job.result["k"], k);
    }
  }
  // The list carries summaries only.
  for (const JobRecord& summary : queue.list()) EXPECT_TRUE(summary.result.is_null());
}

}  // namespace
}  // namespace panelbass::api

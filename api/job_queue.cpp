#include "api/job_queue.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <ctime>
#include <stdexcept>
#include <utility>

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include "api/utc_time.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// Events kept per job: beyond this the oldest progress events are dropped (state events never are), so a
// job reporting every iteration for hours cannot grow without bound.
constexpr std::size_t kMaxEvents = 1000;

constexpr const char* kInterrupted = "interrupted by a restart";

// Niceness of the worker threads: a training job may keep a core busy for minutes, and the audio thread
// (normal priority) must win every contest for a core against it. Raising one's own niceness needs no
// privilege; if the system refuses, the job still runs. A thread already niced beyond it keeps its niceness
// (as root, setting 10 would raise the priority of a service started niced).
constexpr int kWorkerNiceness = 10;

void lower_this_thread_priority() {
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  errno = 0;
  const int now = ::getpriority(PRIO_PROCESS, tid);
  if (errno == 0 && now >= kWorkerNiceness) return;
  (void)::setpriority(PRIO_PROCESS, tid, kWorkerNiceness);
}

bool has_ended(JobState state) {
  return state == JobState::succeeded || state == JobState::failed || state == JobState::cancelled;
}

// The number of a job id "j<number>", or 0 for any other id.
std::uint64_t id_number(const std::string& id) {
  if (id.size() < 2 || id.size() > 19 || id[0] != 'j') return 0;
  std::uint64_t n = 0;
  for (std::size_t i = 1; i < id.size(); ++i) {
    if (id[i] < '0' || id[i] > '9') return 0;
    n = n * 10 + static_cast<std::uint64_t>(id[i] - '0');
  }
  return n;
}

// Natural order of job ids: "j2" before "j10".
bool job_id_less(const std::string& a, const std::string& b) {
  return a.size() != b.size() ? a.size() < b.size() : a < b;
}

// The data of a job's final state event.
json final_state_data(const JobRecord& job) {
  json data = {{"state", job_state_name(job.state)}};
  if (job.state == JobState::failed) data["error"] = job.error;
  return data;
}

// "" as null, so that a client sees "not yet" rather than an empty time.
json string_or_null(const std::string& s) { return s.empty() ? json(nullptr) : json(s); }

std::string optional_string(const json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return "";
  if (!it->is_string()) {
    throw std::invalid_argument(std::string("job.") + key + ": expected a string or null, got " + it->type_name());
  }
  return it->get<std::string>();
}

std::string required_string(const json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end()) throw std::invalid_argument(std::string("job.") + key + ": missing");
  if (!it->is_string()) {
    throw std::invalid_argument(std::string("job.") + key + ": expected a string, got " + it->type_name());
  }
  return it->get<std::string>();
}

// The strings of `object[key]` (absent or null: none); throws naming the field for anything else.
std::vector<std::string> string_list(const json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return {};
  if (!it->is_array()) throw std::invalid_argument(std::string("job.") + key + ": expected an array, got " + it->type_name());
  std::vector<std::string> out;
  for (std::size_t i = 0; i < it->size(); ++i) {
    const json& e = (*it)[i];
    if (!e.is_string()) {
      throw std::invalid_argument(std::string("job.") + key + "[" + std::to_string(i) + "]: expected a string, got " +
                                  e.type_name());
    }
    out.push_back(e.get<std::string>());
  }
  return out;
}

// A result's "warnings" member, taken out of it (a job's work reports them there; JobWork).
std::vector<std::string> take_warnings(json& result) {
  if (!result.is_object() || !result.contains("warnings")) return {};
  std::vector<std::string> out;
  for (const json& w : result["warnings"]) out.push_back(w.is_string() ? w.get<std::string>() : w.dump());
  result.erase("warnings");
  return out;
}

JobState state_from_name(const std::string& name) {
  for (JobState s : {JobState::queued, JobState::running, JobState::succeeded, JobState::failed, JobState::cancelled}) {
    if (name == job_state_name(s)) return s;
  }
  throw std::invalid_argument("job.state: unknown state \"" + name + "\"");
}

}  // namespace

const char* job_state_name(JobState state) {
  switch (state) {
    case JobState::queued: return "queued";
    case JobState::running: return "running";
    case JobState::succeeded: return "succeeded";
    case JobState::failed: return "failed";
    case JobState::cancelled: return "cancelled";
  }
  return "unknown";
}

json job_to_json(const JobRecord& job, bool with_details) {
  json j = {{"id", job.id},
            {"kind", job.kind},
            {"state", job_state_name(job.state)},
            {"progress", job.progress},
            {"message", job.message},
            {"created", string_or_null(job.created)},
            {"started", string_or_null(job.started)},
            {"finished", string_or_null(job.finished)},
            {"error", string_or_null(job.error)},
            {"warnings", job.warnings}};
  if (with_details) {
    j["params"] = job.params;
    j["result"] = job.result;
    // The owner's fields ("activated", …) never replace the record's own.
    if (job.extra.is_object()) {
      for (auto it = job.extra.begin(); it != job.extra.end(); ++it) {
        if (!j.contains(it.key())) j[it.key()] = it.value();
      }
    }
  }
  return j;
}

JobRecord job_from_json(const json& j) {
  if (!j.is_object()) throw std::invalid_argument(std::string("job: expected a JSON object, got ") + j.type_name());
  JobRecord job;
  job.id = required_string(j, "id");
  if (job.id.empty()) throw std::invalid_argument("job.id: empty");
  job.kind = required_string(j, "kind");
  job.state = state_from_name(required_string(j, "state"));
  if (const auto it = j.find("progress"); it != j.end() && !it->is_null()) {
    if (!it->is_number()) throw std::invalid_argument(std::string("job.progress: expected a number, got ") + it->type_name());
    job.progress = it->get<double>();
    if (!(job.progress >= 0.0 && job.progress <= 1.0)) {
      throw std::invalid_argument("job.progress: must be within [0, 1], got " + std::to_string(job.progress));
    }
  }
  job.message = optional_string(j, "message");
  job.created = optional_string(j, "created");
  job.started = optional_string(j, "started");
  job.finished = optional_string(j, "finished");
  job.error = optional_string(j, "error");
  job.warnings = string_list(j, "warnings");
  job.params = j.value("params", json(nullptr));
  job.result = j.value("result", json(nullptr));
  // Whatever else job_to_json() merged in from `extra`; "format" is the store's tag, not the record's.
  static const char* const known[] = {"id",       "kind",     "state", "progress", "message", "created",
                                      "started",  "finished", "error", "params",   "result",  "format", "warnings"};
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (std::find_if(std::begin(known), std::end(known), [&](const char* k) { return it.key() == k; }) ==
        std::end(known)) {
      job.extra[it.key()] = it.value();
    }
  }
  return job;
}

struct JobQueue::Entry {
  JobRecord record;
  JobWork work;
  std::deque<JobEvent> events;
  std::uint64_t next_sequence = 1;
  bool cancel_requested = false;  // a running job stops at its next progress()
  bool finishing = false;         // its end is decided (on_finished may be running); nobody else ends it
};

/// What the work of one job sees of the queue.
class JobQueue::Control : public JobControl {
 public:
  Control(JobQueue& queue, std::shared_ptr<Entry> entry) : queue_(queue), entry_(std::move(entry)) {}

  void progress(double fraction, const std::string& message) override {
    const std::lock_guard lock(queue_.mutex_);
    if (entry_->cancel_requested) throw JobCancelled{};
    JobRecord& record = entry_->record;
    if (std::isfinite(fraction)) record.progress = std::clamp(fraction, 0.0, 1.0);
    record.message = message;
    queue_.publish(*entry_, "progress", {{"progress", record.progress}, {"message", message}});
    queue_.changed_.notify_all();
  }

  bool cancelled() const override {
    const std::lock_guard lock(queue_.mutex_);
    return entry_->cancel_requested;
  }

  // The id never changes after submit(), so it is read without the lock.
  const std::string& job_id() const override { return entry_->record.id; }

 private:
  JobQueue& queue_;
  std::shared_ptr<Entry> entry_;
};

JobQueue::JobQueue(int workers, OnFinished on_finished) : on_finished_(std::move(on_finished)) {
  if (workers < 1) throw std::invalid_argument("JobQueue: workers must be >= 1, got " + std::to_string(workers));
  workers_.reserve(static_cast<std::size_t>(workers));
  for (int i = 0; i < workers; ++i) workers_.emplace_back([this] { worker(); });
}

JobQueue::~JobQueue() {
  std::vector<std::pair<std::shared_ptr<Entry>, JobRecord>> dropped;
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
    for (const std::shared_ptr<Entry>& entry : waiting_) {
      entry->finishing = true;
      JobRecord ended = entry->record;
      ended.state = JobState::cancelled;
      ended.finished = utc_now();
      dropped.emplace_back(entry, std::move(ended));
    }
    waiting_.clear();
    for (auto& [id, entry] : jobs_) {
      if (entry->record.state == JobState::running) entry->cancel_requested = true;
    }
  }
  changed_.notify_all();
  for (auto& [entry, ended] : dropped) finish(entry, std::move(ended));
  // Work that never reports progress holds its worker until it returns.
  for (std::thread& worker : workers_) worker.join();
}

void JobQueue::publish(Entry& entry, const std::string& type, json data) {
  entry.events.push_back(JobEvent{entry.next_sequence++, type, std::move(data)});
  if (entry.events.size() > kMaxEvents) {
    const auto oldest_progress = std::find_if(entry.events.begin(), entry.events.end(),
                                              [](const JobEvent& e) { return e.type == "progress"; });
    if (oldest_progress != entry.events.end()) entry.events.erase(oldest_progress);
  }
}

// on_finished sees the ended record before anyone else does. If it throws, a job that succeeded is failed
// with its message (its result dropped: a result is only shown for a job that succeeded); a job that failed
// or was cancelled keeps its own outcome.
void JobQueue::finish(const std::shared_ptr<Entry>& entry, JobRecord ended) {
  if (on_finished_) {
    std::string error;
    try {
      on_finished_(ended);
    } catch (const std::exception& e) {
      error = e.what();
      if (error.empty()) error = "unknown error";
    } catch (...) {
      error = "unknown error";
    }
    if (!error.empty() && ended.state == JobState::succeeded) {
      ended.state = JobState::failed;
      ended.error = error;
      ended.result = nullptr;
    }
  }
  const std::lock_guard lock(mutex_);
  // Identity and outcome are the queue's; the callback may only add to the record.
  ended.id = entry->record.id;
  ended.kind = entry->record.kind;
  if (!has_ended(ended.state)) ended.state = JobState::failed;
  entry->record = std::move(ended);
  entry->work = nullptr;
  publish(*entry, "state", final_state_data(entry->record));
  drop_old_results();
  changed_.notify_all();
}

// Caller holds mutex_. Newest first: the first kResultsKept finished jobs keep everything.
void JobQueue::drop_old_results() {
  std::size_t finished = 0;
  for (auto it = order_.rbegin(); it != order_.rend(); ++it) {
    Entry& entry = *jobs_.at(*it);
    if (!has_ended(entry.record.state) || !entry.finishing) continue;
    if (++finished <= kResultsKept || entry.record.result_dropped) continue;
    entry.record.result_dropped = true;
    entry.record.result = nullptr;
    entry.record.params = nullptr;
    while (entry.events.size() > 1) entry.events.pop_front();  // the final state event stays
  }
}

void JobQueue::worker() noexcept {
  lower_this_thread_priority();
  for (;;) {
    std::shared_ptr<Entry> entry;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [this] { return stopping_ || !waiting_.empty(); });
      if (stopping_) return;  // the destructor has ended what was waiting
      entry = waiting_.front();
      waiting_.pop_front();
      entry->record.state = JobState::running;
      entry->record.started = utc_now();
      publish(*entry, "state", {{"state", "running"}});
      changed_.notify_all();
    }

    // The work runs without the lock; params and work are not changed while it runs.
    Control control(*this, entry);
    JobState state = JobState::succeeded;
    json result;
    std::string error;
    try {
      result = entry->work(entry->record.params, control);
    } catch (const JobCancelled&) {
      state = JobState::cancelled;
    } catch (const std::exception& e) {
      state = JobState::failed;
      error = e.what();
    } catch (...) {
      state = JobState::failed;
      error = "unknown error";
    }

    JobRecord ended;
    {
      const std::lock_guard lock(mutex_);
      entry->finishing = true;
      ended = entry->record;
    }
    ended.state = state;
    ended.error = error;
    ended.finished = utc_now();
    if (state == JobState::succeeded) {
      ended.warnings = take_warnings(result);
      ended.result = std::move(result);
      ended.progress = 1.0;
    }
    finish(entry, std::move(ended));
  }
}

JobQueueFull::JobQueueFull(std::size_t waiting_jobs, std::size_t most_jobs)
    : std::runtime_error("the job queue is full: " + std::to_string(waiting_jobs) + " jobs wait for a worker (at most " +
                         std::to_string(most_jobs) + "); wait for some to end, or cancel some (DELETE /api/jobs/{id})"),
      waiting(waiting_jobs),
      most(most_jobs) {}

void JobQueue::set_max_waiting(std::size_t most) {
  const std::lock_guard lock(mutex_);
  max_waiting_ = std::max<std::size_t>(most, 1);
}

std::string JobQueue::submit(const std::string& kind, const json& params, JobWork work,
                             const std::function<void(const JobRecord&)>& before_queued) {
  auto entry = std::make_shared<Entry>();
  entry->record.kind = kind;
  entry->record.params = params;
  entry->record.created = utc_now();
  entry->work = std::move(work);
  std::string id;
  {
    const std::lock_guard lock(mutex_);
    if (stopping_) throw std::logic_error("JobQueue::submit: the queue is stopping");
    if (waiting_.size() >= max_waiting_) throw JobQueueFull(waiting_.size(), max_waiting_);
    entry->record.id = "j" + std::to_string(next_number_);
    if (before_queued) before_queued(entry->record);  // may throw: then nothing was queued
    id = entry->record.id;
    ++next_number_;
    publish(*entry, "state", {{"state", "queued"}});
    jobs_[id] = entry;
    order_.push_back(id);
    waiting_.push_back(entry);
  }
  changed_.notify_all();
  return id;
}

void JobQueue::restore(JobRecord job) {
  const std::lock_guard lock(mutex_);
  if (job.id.empty() || jobs_.count(job.id) != 0) return;
  if (!has_ended(job.state)) {
    job.state = JobState::failed;
    job.error = kInterrupted;
    job.result = nullptr;
    if (job.finished.empty()) job.finished = utc_now();
  }
  next_number_ = std::max(next_number_, id_number(job.id) + 1);
  auto entry = std::make_shared<Entry>();
  entry->record = std::move(job);
  entry->finishing = true;
  publish(*entry, "state", final_state_data(entry->record));
  const std::string id = entry->record.id;
  jobs_[id] = entry;
  // Restored jobs may come in any order; the list stays in order of submission (= of id number).
  order_.insert(std::upper_bound(order_.begin(), order_.end(), id, job_id_less), id);
  drop_old_results();
  changed_.notify_all();
}

std::optional<JobRecord> JobQueue::get(const std::string& id) const {
  const std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  return it->second->record;
}

std::vector<JobRecord> JobQueue::list() const {
  const std::lock_guard lock(mutex_);
  std::vector<JobRecord> out;
  out.reserve(order_.size());
  for (const std::string& id : order_) {
    const JobRecord& r = jobs_.at(id)->record;
    JobRecord summary;  // field by field: params and result can be large
    summary.id = r.id;
    summary.kind = r.kind;
    summary.state = r.state;
    summary.progress = r.progress;
    summary.message = r.message;
    summary.error = r.error;
    summary.warnings = r.warnings;
    summary.created = r.created;
    summary.started = r.started;
    summary.finished = r.finished;
    summary.extra = r.extra;
    summary.result_dropped = r.result_dropped;
    out.push_back(std::move(summary));
  }
  return out;
}

std::size_t JobQueue::count(JobState state) const {
  const std::lock_guard lock(mutex_);
  return static_cast<std::size_t>(
      std::count_if(jobs_.begin(), jobs_.end(), [state](const auto& job) { return job.second->record.state == state; }));
}

std::optional<JobState> JobQueue::cancel(const std::string& id) {
  std::unique_lock lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  const std::shared_ptr<Entry> entry = it->second;
  const JobState was = entry->record.state;
  if (was == JobState::running) {
    entry->cancel_requested = true;
  } else if (was == JobState::queued && !entry->finishing) {
    // Ended here, on the caller's thread: on_finished runs before cancel() returns.
    entry->finishing = true;
    waiting_.erase(std::find(waiting_.begin(), waiting_.end(), entry));
    JobRecord ended = entry->record;
    ended.state = JobState::cancelled;
    ended.finished = utc_now();
    lock.unlock();
    finish(entry, std::move(ended));
  }
  return was;
}

// An unknown id gives no events and counts as ended (nothing will ever come).
std::vector<JobEvent> JobQueue::events_after(const std::string& id, std::uint64_t after_sequence,
                                             std::chrono::milliseconds timeout, bool* ended) const {
  std::unique_lock lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) {
    if (ended != nullptr) *ended = true;
    return {};
  }
  const std::shared_ptr<Entry> entry = it->second;
  changed_.wait_for(lock, timeout, [&] {
    return (!entry->events.empty() && entry->events.back().sequence > after_sequence) ||
           has_ended(entry->record.state);
  });
  std::vector<JobEvent> out;
  for (const JobEvent& event : entry->events) {
    if (event.sequence > after_sequence) out.push_back(event);
  }
  // The final state event is published with the final state, so nothing can follow these once it has ended.
  if (ended != nullptr) *ended = has_ended(entry->record.state);
  return out;
}

bool JobQueue::wait(const std::string& id, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return false;
  const std::shared_ptr<Entry> entry = it->second;
  return changed_.wait_for(lock, timeout, [&] { return has_ended(entry->record.state); });
}

}  // namespace panelbass::api

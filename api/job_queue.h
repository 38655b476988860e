#pragma once
// Jobs: long work (identification, design, analysis) run by a small worker pool off the audio thread,
// with progress, cancellation and an event stream a client can follow.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace panelbass::api {

/// Where a job is.
enum class JobState { queued, running, succeeded, failed, cancelled };

/// "queued", "running", "succeeded", "failed", "cancelled".
const char* job_state_name(JobState state);

/// Thrown out of JobControl::progress() once the job has been cancelled; the queue catches it.
struct JobCancelled {};

/// What a running job is given to report progress and notice cancellation.
class JobControl {
 public:
  virtual ~JobControl() = default;
  /// Reports `fraction` (clamped to [0, 1]) done and what is being done; throws JobCancelled if the job
  /// was cancelled. Cheap enough to call once per training iteration.
  virtual void progress(double fraction, const std::string& message) = 0;
  /// True once the job was cancelled (for work that polls instead of reporting).
  virtual bool cancelled() const = 0;
  /// The job's id (e.g. the source recorded with a model it makes).
  virtual const std::string& job_id() const = 0;
};

/// The work of a job: params in, result out; throws (std::exception) to fail with that message. A result's
/// "warnings" member (an array of sentences) becomes the record's `warnings`, not part of the result.
using JobWork = std::function<nlohmann::json(const nlohmann::json& params, JobControl& control)>;

/// One event of a job's stream.
struct JobEvent {
  std::uint64_t sequence = 0;  ///< 1, 2, … per job
  std::string type;            ///< "state" or "progress"
  nlohmann::json data;         ///< {"state":"running"} or {"progress":0.4,"message":"…"}
};

/// Everything known about a job.
struct JobRecord {
  std::string id;                 ///< "j" + number
  std::string kind;               ///< e.g. "identify-linear"
  JobState state = JobState::queued;
  double progress = 0.0;          ///< 0..1
  std::string message;            ///< last progress message
  nlohmann::json params;          ///< as submitted
  nlohmann::json result;          ///< null until succeeded
  std::string error;              ///< why it failed ("" otherwise)
  std::vector<std::string> warnings;  ///< what is wrong with a result that succeeded, and what to try (empty: all is well)
  std::string created, started, finished;  ///< UTC ISO 8601 ("" until it happens)
  nlohmann::json extra = nlohmann::json::object();  ///< set by the owner after it finished (e.g. "activated")
  bool result_dropped = false;    ///< the result was dropped from memory (see JobQueue::kResultsKept); the owner's store has it
};

/// The record as JSON, "warnings" always (an array, empty when all is well); `with_details` adds "params",
/// "result" and the extra fields.
nlohmann::json job_to_json(const JobRecord& job, bool with_details);
/// A record from its JSON form (a stored job); throws std::invalid_argument naming the field.
JobRecord job_from_json(const nlohmann::json& json);

/// A job refused because the queue holds as many waiting jobs as it may (HTTP 429); the message says how many.
class JobQueueFull : public std::runtime_error {
 public:
  /// `waiting` jobs wait, at most `most` may.
  JobQueueFull(std::size_t waiting, std::size_t most);
  std::size_t waiting;  ///< jobs waiting for a worker
  std::size_t most;     ///< the bound
};

/// A worker pool running submitted jobs in order of submission.
class JobQueue {
 public:
  /// Called on the worker thread when a job has ended (succeeded, failed or cancelled), before its final
  /// state event is published; may fill `extra` (e.g. after activating the result) and persist it.
  using OnFinished = std::function<void(JobRecord& job)>;

  /// Starts `workers` (≥ 1) threads.
  explicit JobQueue(int workers, OnFinished on_finished = {});
  /// Cancels what runs, drops what waits (as cancelled) and joins the workers.
  ~JobQueue();
  JobQueue(const JobQueue&) = delete;
  JobQueue& operator=(const JobQueue&) = delete;

  /// At most `most` (≥ 1) jobs may wait for a worker at once; submit() refuses more (JobQueueFull).
  void set_max_waiting(std::size_t most);

  /// Queues `work`; returns the new job's id. Ids continue after the largest restored one.
  /// `before_queued` (if set) sees the queued record before any worker can start it — the place to
  /// persist it, so that a later write of the finished record can never be overtaken; if it throws, the
  /// job is not queued and the exception propagates. Throws JobQueueFull when the waiting jobs are at the bound.
  std::string submit(const std::string& kind, const nlohmann::json& params, JobWork work,
                     const std::function<void(const JobRecord&)>& before_queued = {});
  /// Adds a finished job read back from the store (a queued or running one comes back as failed,
  /// "interrupted by a restart"); an id already known is ignored.
  void restore(JobRecord job);
  /// The record of `id`.
  std::optional<JobRecord> get(const std::string& id) const;
  /// Every job, in order of submission, without params and results (summaries).
  std::vector<JobRecord> list() const;
  /// Finished jobs whose results and events stay in memory (the newest); older ones keep their summary
  /// and final state event only, so memory stays bounded however many jobs run. The owner persists every
  /// record in on_finished and serves dropped results from there.
  static constexpr std::size_t kResultsKept = 64;
  /// Number of jobs in `state`.
  std::size_t count(JobState state) const;
  /// Cancels `id`: a queued job at once, a running one at its next progress report. Returns the state
  /// it had (nullopt if unknown); a finished job is left as it was.
  std::optional<JobState> cancel(const std::string& id);
  /// The events of `id` after `after_sequence`, waiting up to `timeout` for at least one; empty on
  /// timeout or for an unknown id. `ended` is set when the job has ended and no event is left after these.
  std::vector<JobEvent> events_after(const std::string& id, std::uint64_t after_sequence,
                                     std::chrono::milliseconds timeout, bool* ended = nullptr) const;
  /// Waits until `id` has ended or `timeout` passed; true if it ended.
  bool wait(const std::string& id, std::chrono::milliseconds timeout) const;

 private:
  struct Entry;
  class Control;
  void worker() noexcept;
  void drop_old_results();
  // Appends an event to `entry`'s stream (mutex_ held).
  void publish(Entry& entry, const std::string& type, nlohmann::json data);
  // Ends `entry` with the record `ended`: on_finished, then the record and its final state event (mutex_ not held).
  void finish(const std::shared_ptr<Entry>& entry, JobRecord ended);

  OnFinished on_finished_;
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::map<std::string, std::shared_ptr<Entry>> jobs_;
  std::vector<std::string> order_;
  std::deque<std::shared_ptr<Entry>> waiting_;
  std::uint64_t next_number_ = 1;
  std::size_t max_waiting_ = 1000;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace panelbass::api

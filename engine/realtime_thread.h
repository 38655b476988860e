#pragma once
// Real-time scheduling for an audio thread: SCHED_FIFO at a given priority, so that no thread of normal
// priority (HTTP handlers, jobs, other processes) can keep it from its next period; and the process's
// memory locked, so that no page fault (a page swapped out, or touched for the first time) stalls it.

namespace panelbass::engine {

/// Puts the calling thread under SCHED_FIFO at `priority` (1..99); true if the system granted it (it needs
/// CAP_SYS_NICE or an rtprio limit, e.g. from /etc/security/limits.d). A priority ≤ 0 asks for nothing and
/// returns false.
bool make_this_thread_realtime(int priority) noexcept;

/// Locks every page of the process, present and future, in memory (mlockall(MCL_CURRENT | MCL_FUTURE));
/// true if the system granted it (it needs CAP_IPC_LOCK or a memlock limit above the process's size).
/// The lock stays for the life of the process.
bool lock_process_memory() noexcept;

/// What an audio thread was granted when it asked for real-time treatment.
struct RealtimeGrant {
  bool priority = false;       ///< SCHED_FIFO at the asked priority
  bool memory_locked = false;  ///< the process's memory locked (asked only when the priority was granted)
};

/// make_this_thread_realtime(priority), then, if granted, lock_process_memory().
RealtimeGrant make_this_thread_realtime_and_locked(int priority) noexcept;

}  // namespace panelbass::engine

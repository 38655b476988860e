#pragma once
// Real-time scheduling for an audio thread: SCHED_FIFO at a given priority, so that no thread of normal
// priority (HTTP handlers, jobs, other processes) can keep it from its next period.

namespace panelbass::engine {

/// Puts the calling thread under SCHED_FIFO at `priority` (1..99); true if the system granted it (it needs
/// CAP_SYS_NICE or an rtprio limit, e.g. from /etc/security/limits.d). A priority ≤ 0 asks for nothing and
/// returns false.
bool make_this_thread_realtime(int priority) noexcept;

}  // namespace panelbass::engine

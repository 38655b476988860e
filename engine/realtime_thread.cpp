#include "engine/realtime_thread.h"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

namespace panelbass::engine {

bool make_this_thread_realtime(int priority) noexcept {
  if (priority <= 0) return false;
  sched_param param{};
  param.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0;
}

bool lock_process_memory() noexcept { return mlockall(MCL_CURRENT | MCL_FUTURE) == 0; }

RealtimeGrant make_this_thread_realtime_and_locked(int priority) noexcept {
  RealtimeGrant grant;
  grant.priority = make_this_thread_realtime(priority);
  if (grant.priority) grant.memory_locked = lock_process_memory();
  return grant;
}

}  // namespace panelbass::engine

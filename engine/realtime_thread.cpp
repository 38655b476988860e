#include "engine/realtime_thread.h"

#include <pthread.h>
#include <sched.h>

namespace panelbass::engine {

bool make_this_thread_realtime(int priority) noexcept {
  if (priority <= 0) return false;
  sched_param param{};
  param.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0;
}

}  // namespace panelbass::engine

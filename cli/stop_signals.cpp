#include "cli/stop_signals.h"

#include <atomic>

namespace panelbass::cli {
namespace {

// Set by SIGINT/SIGTERM; a lock-free atomic is safe to store from a handler.
std::atomic<bool> interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free);

extern "C" void on_stop_signal(int) { interrupted.store(true, std::memory_order_relaxed); }

}  // namespace

StopSignals::StopSignals() {
  interrupted.store(false, std::memory_order_relaxed);
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, &old_int_);
  sigaction(SIGTERM, &action, &old_term_);
}

StopSignals::~StopSignals() {
  sigaction(SIGINT, &old_int_, nullptr);
  sigaction(SIGTERM, &old_term_, nullptr);
}

bool stop_requested() { return interrupted.load(std::memory_order_relaxed); }

}  // namespace panelbass::cli

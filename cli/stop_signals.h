#pragma once
// SIGINT and SIGTERM as a flag the long-running verbs (run, serve) poll.

#include <signal.h>

namespace panelbass::cli {

/// While alive, SIGINT and SIGTERM set a flag (stop_requested()) instead of killing the process; the
/// previous handlers come back afterwards.
class StopSignals {
 public:
  /// Installs the handlers and clears the flag.
  StopSignals();
  /// Restores the previous handlers.
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

/// True once SIGINT or SIGTERM arrived while a StopSignals lived.
bool stop_requested();

}  // namespace panelbass::cli

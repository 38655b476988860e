#pragma once
// The command line's side of a use case: a progress bar for its reports, a refused request shown as a usage
// error naming the flag, and its warnings on standard error.

#include <map>
#include <string>
#include <vector>

#include "cli/progress_bar.h"
#include "cli/stop_signals.h"
#include "usecases/progress.h"
#include "usecases/request_error.h"

namespace panelbass::cli {

/// A use case's progress as a bar on standard error.
class BarProgress final : public usecases::Progress {
 public:
  /// A bar titled `label`.
  explicit BarProgress(std::string label) : bar_(std::move(label)) {}
  /// Moves the bar.
  void report(double fraction, const std::string&) override { bar_.update(fraction); }

 private:
  ProgressBar bar_;
};

/// What a refused field is on the command line: the flags of the request's fields, and the files some of them name.
struct RequestSpelling {
  /// Field → flag ("max_input" → "--max-input"); a field not here, or the part of it before its first dot, is shown
  /// as "--" + the field with '_' as '-'.
  std::map<std::string, std::string> flags;
  /// Field → the file it was read from: a refusal of such a field is the file's fault (exit 1, "<file>: …").
  std::map<std::string, std::string> files;
};

/// A use case's progress as a bar, and Ctrl-C (or SIGTERM) as a request to end early and keep what was found.
class StoppableBarProgress final : public usecases::Progress {
 public:
  /// A bar titled `label`; the stop signals are caught while it lives.
  explicit StoppableBarProgress(std::string label) : bar_(std::move(label)) {}
  /// Moves the bar.
  void report(double fraction, const std::string&) override { bar_.update(fraction); }
  /// True once a stop signal came.
  bool stopping() const override { return stop_requested(); }

 private:
  StopSignals signals_;
  ProgressBar bar_;
};

/// Runs `verb` (a call of a use case); a RequestError it throws becomes CLI::ValidationError (exit 2) naming the flag
/// of its field, or, for a field read from a file, std::invalid_argument "<file>: <problem>" (exit 1).
template <typename Verb>
auto run_use_case(Verb&& verb, const RequestSpelling& spelling = {}) -> decltype(verb());

/// The flag a request field is spelled as on the command line.
std::string flag_of(const std::string& field, const std::map<std::string, std::string>& flags);

/// Throws what `e` is on the command line (above).
[[noreturn]] void throw_refusal(const usecases::RequestError& e, const RequestSpelling& spelling);

/// Prints each of `warnings` on standard error as "<verb>: <warning>".
void print_warnings(const std::string& verb, const std::vector<std::string>& warnings);

template <typename Verb>
auto run_use_case(Verb&& verb, const RequestSpelling& spelling) -> decltype(verb()) {
  try {
    return verb();
  } catch (const usecases::RequestError& e) {
    throw_refusal(e, spelling);
  }
}

}  // namespace panelbass::cli

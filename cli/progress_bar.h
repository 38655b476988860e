#pragma once
// A progress bar on standard error, for long work started from a terminal.

#include <string>

namespace panelbass::cli {

/// Draws "label [#####.....]  50%" on stderr, redrawn in place on a terminal; when stderr is not a
/// terminal it prints a line at each tenth from 10 % instead, so logs stay readable.
class ProgressBar {
 public:
  /// A bar titled `label`, at 0 %.
  explicit ProgressBar(std::string label);
  /// Finishes the line if the work ended early.
  ~ProgressBar();
  /// Shows `fraction` (0..1) done; never less than already shown.
  void update(double fraction);

 private:
  std::string label_;
  bool terminal_;
  int shown_ = -1;  // last percentage (terminal) or tenth (log) shown
  bool done_ = false;
  double reached_ = 0.0;  // the largest fraction given
};

}  // namespace panelbass::cli

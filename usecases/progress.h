#pragma once
// How a use case tells its door how far it is, and how the door stops it: the CLI draws a bar, the API
// turns each report into a job event and throws from it when the job was cancelled.

#include <string>

namespace panelbass::usecases {

/// The door's side of a running use case.
class Progress {
 public:
  virtual ~Progress() = default;
  /// `fraction` (0..1) of the work done and what is being done; may throw to stop the work (a cancelled job).
  virtual void report(double fraction, const std::string& message) = 0;
  /// True when the door asks the work to end early and keep what it found so far (Ctrl-C on a terminal).
  virtual bool stopping() const { return false; }
};

/// A Progress that shows nothing and never stops the work.
class SilentProgress final : public Progress {
 public:
  /// Does nothing.
  void report(double, const std::string&) override {}
};

/// A stage of a use case as a span [lo, hi] of its door's progress: a stage's own fractions are mapped onto it,
/// and the fraction reported never goes back.
class ProgressSpan final : public Progress {
 public:
  /// Reports to `outer`, mapping [0, 1] onto [lo, hi].
  ProgressSpan(Progress& outer, double lo, double hi) : outer_(outer), lo_(lo), hi_(hi) {}
  /// Reports lo + fraction·(hi − lo) to the outer progress.
  void report(double fraction, const std::string& message) override;
  /// The outer progress's.
  bool stopping() const override { return outer_.stopping(); }

 private:
  Progress& outer_;
  double lo_, hi_;
};

}  // namespace panelbass::usecases

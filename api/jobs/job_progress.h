#pragma once
// A job's progress across its stages: each stage's own fraction is mapped onto its span of the job, and
// the reported fraction never goes back.

#include <string>

#include "api/job_queue.h"
#include "usecases/progress.h"

namespace panelbass::api {

/// Progress of one job. JobCancelled thrown by the control unwinds whatever called at().
class JobProgress final : public usecases::Progress {
 public:
  /// Reports through `control`.
  explicit JobProgress(JobControl& control) : control_(control) {}
  /// The next stage covers [lo, hi] of the job.
  void span(double lo, double hi);
  /// Reports `fraction` of the current stage (non-finite counts as 0; clamped to [0, 1]).
  void at(double fraction, const std::string& message);
  /// A use case's report: at().
  void report(double fraction, const std::string& message) override { at(fraction, message); }

 private:
  JobControl& control_;
  double lo_ = 0.0, hi_ = 1.0, last_ = 0.0;
};

}  // namespace panelbass::api

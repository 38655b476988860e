#include "cli/progress_bar.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace panelbass::cli {

ProgressBar::ProgressBar(std::string label) : label_(std::move(label)), terminal_(isatty(STDERR_FILENO) != 0) {}

ProgressBar::~ProgressBar() {
  if (terminal_ && shown_ >= 0 && !done_) std::fputc('\n', stderr);
}

void ProgressBar::update(double fraction) {
  // NaN (0/0 of no work): nothing new done; a stage that restarts its own count never moves the bar back.
  const double f = std::max(reached_, std::isnan(fraction) ? 0.0 : std::clamp(fraction, 0.0, 1.0));
  reached_ = f;
  const int percent = static_cast<int>(f * 100.0);
  if (terminal_) {
    if (percent == shown_) return;
    shown_ = percent;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(f * kWidth);
    std::fprintf(stderr, "\r%s [%s%s] %3d%%", label_.c_str(), std::string(filled, '#').c_str(),
                 std::string(kWidth - filled, '.').c_str(), percent);
  } else {
    const int tenth = percent / 10;
    if (tenth == shown_) return;
    shown_ = tenth;
    if (tenth == 0) return;  // a log line says what was done: "0 %" says nothing (and would stand before an error)
    std::fprintf(stderr, "%s: %d%%\n", label_.c_str(), tenth * 10);
  }
  if (percent == 100 && !done_) {
    done_ = true;
    if (terminal_) std::fputc('\n', stderr);
  }
  std::fflush(stderr);
}

}  // namespace panelbass::cli

#pragma once
// Whether a signal repeats, and with which period: periodic excitation (a multisine played several times)
// lets distortion be told from noise line by line.

#include <Eigen/Core>

namespace panelbass::dsp {

/// How find_period decides that a signal repeats.
struct PeriodSearch {
  double tolerance = 0.05;        ///< rms of x(k+P) − x(k) over the rms of x, at most (a measured input's noise)
  Eigen::Index min_period = 16;   ///< shortest period considered, samples
  Eigen::Index min_repeats = 2;   ///< whole periods the signal must hold at least
};

/// The fundamental period of `x` in samples: the shortest lag P at which x(k+P) − x(k) is within the
/// tolerance, a local minimum, and no more than twice the smallest such difference over every lag (so a
/// slowly varying signal does not pass for repeating at a short lag). 0 when x does not repeat, is
/// constant, or is too short for min_repeats periods. Cost O(N log N) (one FFT autocorrelation).
Eigen::Index find_period(const Eigen::VectorXd& x, const PeriodSearch& search = {});

/// The whole number of periods m in [least, most] whose length m·period (samples, not necessarily whole) is
/// closest to a whole number of samples, the largest m on a tie: the stretch a single-bin DFT, or a loop
/// without a click, wants. `least` when most < least.
long closest_whole_periods(double period, long most, long least);

}  // namespace panelbass::dsp

#pragma once
// Harmonic levels of a steady-state sine response.

#include <Eigen/Core>
#include <complex>
#include <optional>
#include <vector>

namespace panelbass::dsp {

/// Amplitudes of a fundamental and its harmonics.
struct HarmonicLevels {
  double frequency = 0.0;              ///< fundamental, Hz
  std::vector<double> amplitude;       ///< amplitude[h-1] of harmonic h (h = 1 is the fundamental)
  std::vector<double> phase;           ///< phase[h-1] of harmonic h, radians: x(k) ≈ Σ_h a_h·cos(2π·h·f·k/fs + φ_h)
  /// Total harmonic distortion in percent: sqrt(Σ_{h≥2} a_h²) / a_1.
  double thd_percent() const;
  /// Level of harmonic h relative to the fundamental, dB (−inf for a zero harmonic).
  double relative_db(std::size_t h) const;
  /// Harmonic h relative to the fundamental, (a_h/a_1)·e^{j(φ_h − h·φ_1)}: its level, and its phase when the
  /// fundamental is written as a cosine of phase zero. A delay of the whole signal leaves it unchanged, so a
  /// model's harmonics can be set against a recording's whatever the delay between them.
  std::complex<double> relative(std::size_t h) const;
};

/// Amplitudes and phases of harmonics 1..max_order (those below fs/2) of `x` at `frequency`, by the DFT at each
/// harmonic's frequency. For exact results x holds a whole number of periods (stepped_sine ensures it).
HarmonicLevels harmonic_levels(const Eigen::VectorXd& x, double fs, double frequency, int max_order = 5);

/// THD (percent) of the steady state of a sine response `y` at `frequency`: its last three quarters, cut to
/// the whole number of periods whose length is closest to a whole number of samples (closest_whole_periods,
/// at least half of those that fit), so the single-bin DFT of harmonic_levels is exact. Empty when fewer
/// than 4 periods are left or the THD is not finite.
std::optional<double> steady_thd_percent(const Eigen::VectorXd& y, double fs, double frequency, int max_order = 5);

}  // namespace panelbass::dsp

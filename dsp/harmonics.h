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

/// A steady sine response's THD and the noise it stands on, over steady_thd_percent's stretch.
struct SteadyThd {
  double thd_pct = 0.0;          ///< the harmonics' THD with the noise's expected share taken out (≥ 0)
  double measured_thd_pct = 0.0; ///< the THD as the single-bin DFTs read it (steady_thd_percent), noise included
  double floor_pct = 0.0;        ///< the THD the noise alone shows: sqrt(count·4σ²/N)/a₁, σ from the residual
  double uncertainty_db = 0.0;   ///< one standard deviation of thd_pct from that noise, dB (inf when thd_pct = 0)
  bool at_floor = false;         ///< the measured THD within 3 dB of the floor: what it reads is the noise's
  double fundamental = 0.0;      ///< the fundamental's amplitude a₁ over the stretch
  Eigen::Index samples = 0;      ///< the stretch's length N
};

/// steady_thd_percent with the noise measured: the residual of the stretch after its mean and its harmonics
/// (each bin's sine) gives the noise's σ², each harmonic's single-bin amplitude carries 4σ²/N of it in mean
/// square, and that much is taken out of each. Empty when steady_thd_percent is.
std::optional<SteadyThd> steady_thd(const Eigen::VectorXd& y, double fs, double frequency, int max_order = 5);

}  // namespace panelbass::dsp

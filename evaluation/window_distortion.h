#pragma once
// The distortion of a transducer judged from its own side: one window of the drive it received, its sensor's
// reading and its noise-free acceleration (a JACK transducer's record window), read as a sine response — the
// drive's dominant frequency, each signal's fundamental there and the THD of harmonics 2..5
// (dsp::steady_thd over the window's steady three quarters).

#include <Eigen/Core>
#include <optional>

namespace panelbass::evaluation {

/// What one window says.
struct WindowDistortion {
  double drive_rms = 0.0;                   ///< the drive's RMS
  double drive_peak = 0.0;                  ///< the drive's largest |sample|
  std::optional<double> frequency_hz;       ///< the drive's dominant frequency (none: a silent drive)
  double drive_fundamental = 0.0;           ///< the drive's amplitude at it
  double sensor_fundamental = 0.0;          ///< the sensor's amplitude at it (its units, e.g. V)
  double clean_fundamental = 0.0;           ///< the noise-free acceleration's amplitude at it
  std::optional<double> drive_thd_pct;      ///< THD of the drive itself, harmonics 2..5, %
  std::optional<double> clean_thd_pct;      ///< THD of the noise-free acceleration, harmonics 2..5, %
  std::optional<double> sensor_thd_pct;     ///< THD of the sensor with the noise's share taken out (SteadyThd::thd_pct)
  std::optional<double> sensor_measured_thd_pct;  ///< the sensor's THD as read, noise included
  std::optional<double> sensor_floor_pct;   ///< the THD the sensor's noise alone shows
  bool sensor_at_floor = false;             ///< the sensor's THD within 3 dB of its floor
};

/// The distortion figures of one window at rate `fs` (equal-length columns; a drive whose RMS is below 1e-9
/// has no frequency and no THD). Fundamentals and THDs are over steady_thd's stretch (the last three quarters
/// cut to whole periods); empty (fundamentals 0) when fewer than 4 periods fit or no harmonic is below fs/2.
WindowDistortion window_distortion(const Eigen::VectorXd& drive, const Eigen::VectorXd& sensor,
                                   const Eigen::VectorXd& clean, double fs);

}  // namespace panelbass::evaluation

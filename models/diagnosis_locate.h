#pragma once
// Diagnosis, step one: where a simulation and a recording disagree. The residual of a simulation is
// located in frequency (against the noise floor), in amplitude (against the input level), and in time
// (drift between the start and the end of the record); see ../shared/PHYSICS.md.

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace panelbass::models {

/// Where the residual e = y − ŷ of one record lies.
struct ResidualLocation {
  double noise_psd = 0.0;          ///< white-noise level of the residual, units²/Hz (median of the top band)
  double noise_floor_pct = 0.0;    ///< that noise's share of Σy², percent (J of a perfect model)
  double residual_pct = 0.0;       ///< J of the simulation, percent
  double peak_frequency_hz = 0.0;  ///< frequency of the largest residual PSD bin above DC
  double peak_over_noise = 0.0;    ///< that bin's PSD divided by the noise level
  double peak_threshold = 0.0;     ///< the ratio pure noise exceeds with probability ≈ 0.1 % at any bin
  double mean = 0.0;               ///< residual mean
  double mean_t = 0.0;             ///< mean / its standard error (from 20 block means)
  double level_ratio = 1.0;        ///< residual rms in the top quartile of |u| over that in the bottom
  double drift_ratio = 1.0;        ///< residual rms in the last quarter of the record over the first
  double gain_drift = 0.0;         ///< LS gain of y on ŷ in the last quarter minus that in the first
  int xcorr_lag = 0;               ///< lag (samples, ±10) of the largest input–residual cross-correlation
  double xcorr_peak = 0.0;         ///< that normalised correlation
};

/// Locates the residual `y − y_sim` over samples [start, end) at sample rate `fs`; u is the input.
/// Throws std::invalid_argument for unequal lengths or fewer than 256 samples after `start`.
ResidualLocation locate_residual(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const Eigen::VectorXd& y_sim,
                                 double fs, Eigen::Index start);

/// The location as JSON (every field, named as in the struct).
nlohmann::json location_to_json(const ResidualLocation& location);

}  // namespace panelbass::models

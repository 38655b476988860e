#pragma once
// Diagnosis, step one: where a simulation and a recording disagree. The residual of a simulation is
// located in frequency (against the noise floor, as an FRF error, and as odd/even distortion at the empty
// lines of periodic data), in amplitude and state (against the input and output level, the estimated
// velocity and displacement and the direction of motion), and in time (drift, and the onset of a change);
// see docs/transducer.md.

#include <Eigen/Core>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace panelbass::models {

// The significance verdicts of the location's statistics, decided here once (the JSON carries them, so the
// reports and the web UI show them instead of judging the numbers again).

/// χ²/bin above which a state's bin means show a dependence: noise gives ≈ 1 (spread √(2/11) over 12 bins), 3 is far in its tail.
inline constexpr double kShapeChi2Significant = 3.0;
/// |t| above which a direction or level-change statistic counts: 4 standard errors, rare for noise even over the searches made.
inline constexpr double kTSignificant = 4.0;

/// Whether a state's bin means depend on it beyond noise: shape_chi2 > kShapeChi2Significant.
bool state_dependence_significant(double shape_chi2);
/// Whether a t statistic lies beyond kTSignificant standard errors, of either sign.
bool t_significant(double t);
/// Whether the residual's spectral peak rises above what noise reaches: peak_over_noise > peak_threshold.
bool peak_significant(double peak_over_noise, double peak_threshold);

/// The linear part of the residual: H_ue = H_uy − H_uŷ, the FRF error, where the input explains the residual.
struct FrfError {
  double frequency_hz = 0.0;   ///< the bin whose residual the input explains most (largest coherence γ²_ue)
  double coherence = 0.0;      ///< γ²_ue there
  double threshold = 1.0;      ///< the coherence pure noise exceeds at any bin of the band with probability ≈ 1 %
  double relative_db = -std::numeric_limits<double>::infinity();  ///< 20·log10|H_ue/H_uy| there
  double band_low_hz = 0.0;    ///< the contiguous band around it where γ²_ue is above the threshold
  double band_high_hz = 0.0;
  bool significant = false;    ///< coherence > threshold: the simulation's frequency response is wrong there
};

/// Nonlinear distortion of periodic data at the lines its input leaves empty.
struct PeriodicDistortion {
  bool periodic = false;          ///< the input repeats (dsp::find_period) at least three times after init
  Eigen::Index period = 0;        ///< samples
  int periods = 0;                ///< whole periods judged (after one period to settle)
  int excited_lines = 0;          ///< DFT lines of a period carrying the input
  bool odd_lines_only = false;    ///< every excited line is odd: even and odd distortion can be told apart
  double output_even_db = std::numeric_limits<double>::quiet_NaN();    ///< y at the empty even lines over its noise
  double output_odd_db = std::numeric_limits<double>::quiet_NaN();     ///< y at the empty odd lines over its noise
  double residual_even_db = std::numeric_limits<double>::quiet_NaN();  ///< the same of y − ŷ: what the simulation leaves
  double residual_odd_db = std::numeric_limits<double>::quiet_NaN();
  double threshold_db = 3.0;      ///< above which distortion counts as seen
};

/// The residual against one state: its mean in bins of the state, and how it depends on the direction.
struct StateProfile {
  std::string state;           ///< "input", "output", "integral", "double_integral" (see StateProxy)
  Eigen::VectorXd centre;      ///< bin centres (equal-count bins), in units of the state's rms about its mean
  Eigen::VectorXd mean;        ///< the residual's mean in each bin, output units
  double level_ratio = 1.0;    ///< residual rms where |state| is in its top quartile over its bottom quartile
  double shape_chi2 = 0.0;     ///< Σ (bin mean / its standard error)² / bins: ≈ 1 when the residual ignores the state
  double direction_t = 0.0;    ///< (residual mean while the state rises − while it falls) / its standard error
  bool shape_significant = false;      ///< state_dependence_significant(shape_chi2): the residual depends on this state
  bool direction_significant = false;  ///< t_significant(direction_t): it differs between rising and falling
};

/// Where the residual e = y − ŷ of one record lies.
struct ResidualLocation {
  double noise_psd = 0.0;          ///< white-noise level of the residual, units²/Hz (median of the top band)
  double noise_floor_pct = 0.0;    ///< that noise's share of Σy², percent (J of a perfect model)
  double noise_floor_relative_sd = 0.0;  ///< that estimate's standard uncertainty over it (a median of averaged bins)
  double residual_pct = 0.0;       ///< J of the simulation, percent
  double peak_frequency_hz = 0.0;  ///< frequency of the largest residual PSD bin above DC
  double peak_over_noise = 0.0;    ///< that bin's PSD divided by the noise level
  double peak_threshold = 0.0;     ///< the ratio pure noise exceeds with probability ≈ 0.1 % at any bin
  bool peak_significant = false;   ///< peak_significant(peak_over_noise, peak_threshold): the peak is not noise
  double mean = 0.0;               ///< residual mean
  double mean_t = 0.0;             ///< mean / its standard error (from 20 block means)
  double level_ratio = 1.0;        ///< residual rms in the top quartile of |u| over that in the bottom
  double drift_ratio = 1.0;        ///< residual rms in the last quarter of the record over the first
  double gain_drift = 0.0;         ///< LS gain of y on ŷ in the last quarter minus that in the first
  int xcorr_lag = 0;               ///< lag (samples, ±10) of the largest input–residual cross-correlation
  double xcorr_peak = 0.0;         ///< that normalised correlation
  double output_level_ratio = 1.0; ///< residual rms where |ŷ| is in its top quartile over its bottom quartile
  double change_time_s = 0.0;      ///< where the residual's level changes most (from the record's first sample)
  double change_ratio = 1.0;       ///< residual rms after that time over before
  double change_t = 0.0;           ///< the change of log block power over its standard error (Welch's t)
  bool change_significant = false; ///< t_significant(change_t): the residual's level changes through the record
  double effective_samples = 0.0;  ///< N shrunk by the residual's own correlation (for the standard errors)
  FrfError frf_error;
  PeriodicDistortion distortion;
  std::vector<StateProfile> states;  ///< input, output, integral, double integral of the simulated output
};

/// Locates the residual `y − y_sim` over samples [start, end) at sample rate `fs`; u is the input. The
/// states are the input and the simulated output with its leaky single and double integrals
/// (state_signals): velocity and displacement for an accelerometer, their integrals for a displacement
/// sensor. Throws std::invalid_argument for unequal lengths or fewer than 256 samples after `start`.
ResidualLocation locate_residual(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const Eigen::VectorXd& y_sim,
                                 double fs, Eigen::Index start);

/// The location as JSON (every field, named as in the structs; `frf_error`, `distortion` and `states` nested).
nlohmann::json location_to_json(const ResidualLocation& location);

}  // namespace panelbass::models

#pragma once
// The best linear approximation (BLA) of a system from periodic random-phase multisine experiments,
// with noise and nonlinear distortion told apart (Pintelon & Schoukens, "System Identification: a
// frequency domain approach", 2nd ed. 2012, §3.4 and §4.3 "robust method"): noise changes from one
// period to the next; the stochastic nonlinear distortion repeats every period but changes from one
// phase realisation to the next; the detection lines an odd multisine leaves empty show even- and
// odd-order distortion separately.

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "dsp/excitation.h"

namespace panelbass::dsp {

/// How the records of a BLA experiment are laid out.
struct BlaSpec {
  std::size_t period = 0;               ///< N: samples per period (the DFT length)
  std::size_t transient_periods = 1;    ///< periods dropped at the start of every record (settling)
  double fs = 0.0;                      ///< sample rate, Hz (for the frequency axes only)
  std::vector<std::size_t> excited_lines;  ///< DFT bins k excited, the same in every realisation
  double detection_threshold_db = 3.0;  ///< output/noise power ratio above which distortion counts as seen
  /// Top of the band searched for distortion, Hz (the multisine's f_max, so that a detection line above
  /// the highest excited line counts); 0 = the highest excited line.
  double detection_f_max = 0.0;
};

/// Output at the lines a multisine leaves empty, and the noise there.
struct DetectionLines {
  std::vector<std::size_t> lines;   ///< DFT bins, ascending
  Eigen::VectorXd frequency;        ///< Hz
  Eigen::VectorXd level;            ///< output sine amplitude 2|Ŷ(k)|/N, rms over realisations
  Eigen::VectorXd noise;            ///< standard deviation of that amplitude due to noise (rms over realisations)
  /// 10·log10(Σ level² / Σ noise²) over the lines: ≈ 0 dB when only noise lands there (NaN if no lines
  /// or fewer than 2 periods).
  double level_to_noise_db = 0.0;
  bool distortion_detected = false; ///< level_to_noise_db > BlaSpec::detection_threshold_db
};

/// The BLA at the excited lines with its noise and stochastic nonlinear variances, and the detection lines.
struct BestLinearApproximation {
  std::size_t realisations = 0;     ///< M: phase realisations
  std::size_t periods = 0;          ///< P: steady-state periods per realisation
  std::vector<std::size_t> lines;   ///< the excited DFT bins k
  Eigen::VectorXd frequency;        ///< k·fs/N, Hz
  Eigen::VectorXcd g;               ///< G_BLA(k): Y/U averaged over periods, then over realisations
  /// Variance of G_BLA caused by noise, from the period-to-period variation (NaN if P < 2).
  Eigen::VectorXd noise_variance;
  /// Total variance of G_BLA, from the realisation-to-realisation variation (NaN if M < 2).
  Eigen::VectorXd total_variance;
  /// Variance of G_BLA caused by the stochastic nonlinear distortion: total − noise, clipped at 0
  /// (a negative difference is estimation scatter: no distortion detectable there). noise_variance already
  /// carries the averaging's 1/P, so this is "total − σ²_n/P" with σ²_n the variance of one period's G
  /// (over M realisations); NaN if M < 2 or P < 2.
  Eigen::VectorXd nonlinear_variance;
  Eigen::VectorXd output_level;     ///< output sine amplitude 2|Ŷ(k)|/N at the excited lines, rms over realisations
  /// Empty even lines from 1 to the top of the band (BlaSpec::detection_f_max): even-order distortion
  /// (filled only when every excited line is odd; then odd-order products, sums of three odd lines, cannot
  /// land there).
  DetectionLines even;
  /// Empty odd lines from 1 to the top of the band (the lines random_odd leaves out, and any odd line
  /// below the band): odd-order distortion (filled only when every excited line is odd).
  DetectionLines odd;
};

/// BLA of the system that turned u[m] into y[m] for every realisation m (records of equal length,
/// (transient_periods + P)·N samples). Throws std::invalid_argument for inconsistent sizes, lines outside
/// 0 < k < N/2 or not ascending, and an input without power at an excited line (120 dB below the mean).
BestLinearApproximation best_linear_approximation(const std::vector<Eigen::VectorXd>& u,
                                                  const std::vector<Eigen::VectorXd>& y, const BlaSpec& spec);

/// Phase realisations of one random-phase multisine: the same lines, new random phases.
struct MultisineRealisations {
  std::vector<Eigen::VectorXd> signals;       ///< spec.periods·spec.period samples each, peak spec.amplitude
  std::vector<std::size_t> lines;             ///< excited bins (those multisine(spec) picks), shared by all
  std::vector<std::size_t> detection_lines;   ///< odd bins left out (random_odd), shared by all
};

/// `realisations` multisines on the lines multisine(spec) picks; realisation 0 is multisine(spec) itself,
/// the others draw their phases from seeds derived from spec.seed. Throws like multisine, and
/// std::invalid_argument for zero realisations.
MultisineRealisations multisine_realisations(const MultisineSpec& spec, std::size_t realisations);

}  // namespace panelbass::dsp

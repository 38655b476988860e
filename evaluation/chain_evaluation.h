#pragma once
// Evaluation of a controller chain on a simulated transducer (the Control issue's table): the chain is
// rendered offline, through exactly the code the real-time backends run, into the virtual transducer —
// not into the model the controllers were designed on — for three configurations: the plant alone,
// band-pass + feedforward, and band-pass + feedforward + feedback.

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "dsp/harmonics.h"
#include "engine/chain_file.h"
#include "models/control/model_probes.h"
#include "models/plant/plant_config.h"

namespace panelbass::evaluation {

// The engine's chain, judged here offline.
using engine::ChainConfig;

/// What the evaluation measures.
struct EvaluationOptions {
  std::vector<double> probe_hz = models::evaluation_probe_hz();  ///< sine frequencies of the distortion probe
  double ripple_low_hz = 20.0;     ///< the band whose response ripple is measured
  double ripple_high_hz = 1200.0;  ///< (upper edge)
  Eigen::Index noise_samples = 60000;  ///< white-noise record for the response and J_c
  std::uint64_t seed = 1;          ///< noise program and sensor noise
  int harmonics = 5;               ///< harmonics analysed per probe
  double probe_peak = 0.0;         ///< steady peak of the band-pass + feedforward output at each probe, in
                                   ///< (0, 1]; 0 = the limiter's knee (the largest peak the chain passes unchanged)
};

/// One probe sine's result.
struct ProbeResult {
  double frequency_hz = 0.0;    ///< the probe frequency
  double amplitude = 0.0;       ///< program amplitude (the largest safe one for band-pass + feedforward)
  double drive_peak = 0.0;      ///< largest |drive| over the analysed part: the steady drive this probe runs at
  double h2_db = 0.0;           ///< 2nd harmonic relative to the fundamental, dB
  double h3_db = 0.0;           ///< 3rd harmonic relative to the fundamental, dB
  double thd_pct = 0.0;         ///< total harmonic distortion, percent
  std::vector<double> harmonics_db;  ///< harmonics 2..n relative to the fundamental, dB (−inf when absent)
  /// THD the design's NARX plant model predicts for this configuration at this probe, percent: the model driven
  /// by what the row's stages make of the same sine (the neural feedback in closed loop with it, model mode).
  /// What the design expected, beside what the transducer did; NaN for a chain without a neural feedback stage.
  double model_thd_pct = std::numeric_limits<double>::quiet_NaN();
};

/// One configuration's row of the table.
struct EvaluationRow {
  std::string name;                  ///< "plant", "band-pass + feedforward", "band-pass + feedforward + feedback"
  double ripple_db = 0.0;            ///< max − min of |program → transducer output| over the band, dB: the
                                     ///< output without the sensor's noise, what the chain and transducer do
  double jc_pct = 0.0;               ///< [2C] J_c of that output against the desired response
  double measured_ripple_db = 0.0;   ///< the ripple as the noisy sensor measures it (what a recording shows)
  double measured_jc_pct = 0.0;      ///< J_c of the sensor's noisy output: about jc_pct + the noise floor
  double max_drive = 0.0;            ///< largest |drive| over every run of this row
  double rail_fraction = 0.0;        ///< share of drive samples above the limiter's knee
  double rest_drive_peak = 0.0;      ///< largest |drive| for a silent program (after settling): what the chain
                                     ///< drives with no input, an offset a coil turns into displacement
  std::uint64_t faults = 0;          ///< times the chain dropped to its safe bypass
  std::vector<ProbeResult> probes;   ///< one per probe frequency
  Eigen::VectorXd response_hz;       ///< frequencies of the response |program → transducer output| (H1, Welch)
  Eigen::VectorXd response_db;       ///< its magnitude, dB (the output without the sensor's noise)
};

/// The whole evaluation.
struct ChainEvaluation {
  double noise_amplitude = 0.0;      ///< amplitude of the uniform white-noise program
  double jc_noise_floor_pct = 0.0;   ///< the J_c the sensor noise alone gives: noise power / desired power
  std::vector<EvaluationRow> rows;   ///< plant, band-pass + feedforward, and (with a feedback stage) the full chain
};

/// Evaluates `config` on `plant`. The chain must have a feedforward stage of kind "lq_feedforward": its
/// desired response ([7B] y_lin) on the band-passed program is the J_c reference, and its largest safe
/// amplitudes set the program levels (the noise case of models::max_input for the noise record; for a
/// probe sine, the amplitude at which band-pass + feedforward reach a steady peak of probe_peak, by default
/// the safety limiter's knee: the largest peak the chain passes undistorted). Distortion is a property of
/// the transducer and the chain: the probes run with the plant's sensor noise switched off, so that it
/// does not set a floor under the harmonics. The response and J_c are taken from the transducer's output
/// without the sensor's noise (the chain itself still sees the noisy sensor), and again from the noisy
/// output as a recording would show them. The output's mean is removed before J_c (an accelerometer is
/// AC-coupled). Throws std::invalid_argument (naming what)
/// for a chain without an LQ feedforward stage, a plant at another rate, or bad options.
ChainEvaluation evaluate_chain(const ChainConfig& config, const models::PlantConfig& plant,
                               const EvaluationOptions& options = {});

}  // namespace panelbass::evaluation

#pragma once
// Everything the Analysis report says about one model on one record, computed in one place so that the
// CLI (`panelbass analyze`) and, later, the API only format it: J by simulation and prediction, the
// Billings–Voon residual tests, the residual's spectrum against the noise floor, the measured frequency
// response with its coherence against the model's, poles, zeros and the root locus of a linear model,
// J per training iteration, and (with the plant at hand) harmonic distortion of plant and model.

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/analysis/distortion_comparison.h"
#include "models/kinds/model_file.h"
#include "models/plant/plant_config.h"
#include "models/validation/residual_tests.h"
#include "models/control/root_locus.h"

namespace panelbass::models {

/// What to analyse and how.
struct AnalysisSpec {
  Eigen::Index init = 50;          ///< measured outputs that set the model's state; everything is judged after them
  int max_lag = 20;                ///< lags of the residual correlation tests
  std::size_t segment = 0;         ///< Welch segment (FFT length); 0 = the largest power of 2 ≤ min(4096, N/4), ≥ 64
  /// Linear model without a given history: output-error iterations run from the model on the analysed data,
  /// whose J per iteration is the training figure (0 = none).
  int refine_iterations = 20;
  /// Root-locus gains in raw units (drive per output unit); NaN = from the small-gain bound ±1/‖G‖∞, doubled
  /// until the closed loop is unstable (at most 2²⁰ times), so the stable interval around k = 0 is inside.
  double gain_min = std::numeric_limits<double>::quiet_NaN();
  double gain_max = std::numeric_limits<double>::quiet_NaN();
  int gain_points = 201;           ///< gains on the root-locus grid
  std::optional<PlantConfig> plant;  ///< the plant the data came from: harmonic distortion and the sensor-noise floor
  DistortionSpec distortion;       ///< the stepped sine measured on plant and model (with `plant`)
  std::function<void(const std::string& stage, double fraction)> progress;
};

/// One point of a training history.
struct HistoryPoint {
  int iteration = 0;
  std::string mode;                ///< "oe", "pem", "oem-d", … ("" when unknown)
  double j_est_pct = 0.0;          ///< simulation J on the estimation (or analysed) data
  double j_val_pct = std::numeric_limits<double>::quiet_NaN();  ///< on validation data, NaN without
};

/// J per iteration and where it came from.
struct TrainingHistory {
  std::string source;              ///< e.g. "model file meta.history", "history.json", "OE refinement on the data"
  std::vector<HistoryPoint> points;
};

/// Spectra of output and residual, and the floors a model cannot go below.
struct ResidualSpectrum {
  Eigen::VectorXd frequency;       ///< Hz, bins 0..segment/2
  Eigen::VectorXd output_psd;      ///< S_yy of the measured output, mean removed (units²/Hz)
  Eigen::VectorXd residual_psd;    ///< S_εε of y − ŷ, mean removed
  /// (1 − γ²)·S_yy: the output not linearly coherent with the input (noise plus nonlinear distortion),
  /// which a linear model's residual cannot go below; γ² corrected for the averaging bias. An upper
  /// estimate: leakage from an impulse response that is not short against the segment lowers γ² and adds
  /// to it.
  Eigen::VectorXd noncoherent_psd;
  /// The plant's sensor noise, 2σ²/fs (white, one-sided); NaN without a plant.
  double sensor_noise_psd = std::numeric_limits<double>::quiet_NaN();
  std::size_t segment = 0;         ///< Welch segment used
};

/// The measured frequency response with its coherence, and the model's.
struct FrfComparison {
  Eigen::VectorXd frequency;       ///< Hz
  Eigen::VectorXcd measured;       ///< H1 = S_uy/S_uu of the data, raw units
  Eigen::VectorXcd model;          ///< the model's response, raw units
  Eigen::VectorXd coherence;       ///< γ² of the data
  std::string model_source;        ///< "transfer function" (linear) or "H1 of the simulated output" (NARX)
};

/// Poles, zeros and the root locus of a linear model under constant output feedback u = r − k·y.
struct PoleZeroAnalysis {
  Eigen::VectorXcd poles, zeros;
  double gain_min = 0.0, gain_max = 0.0;   ///< the locus's gain range, raw units
  std::vector<ClosedLoop> locus;           ///< closed loops on the grid, gains raw
  ClosedLoop open_loop;                    ///< k = 0
  ClosedLoop best;                         ///< shortest impulse response, gain raw
  double best_gain_scaled = 0.0;           ///< the same gain in the model's scaled units
};

/// The whole analysis of one model on one record.
struct ModelAnalysis {
  std::string kind;                ///< "linear" or "narx"
  double fs = 0.0;
  Eigen::Index samples = 0;        ///< samples judged (after init)
  Eigen::Index init = 0;
  double j_sim_pct = 0.0;          ///< [2A] free-run simulation J
  double j_pred_pct = 0.0;         ///< one-step prediction J
  double rmse = 0.0;               ///< of the simulation, raw units
  /// J a perfect linear time-invariant model would leave, from the coherence: Σ(1−γ²)S_yy·df / mean(y²)
  /// (an upper estimate, see ResidualSpectrum::noncoherent_psd).
  double j_noncoherent_pct = 0.0;
  double j_noise_pct = std::numeric_limits<double>::quiet_NaN();  ///< σ²/mean(y²) of the plant's sensor noise
  Eigen::VectorXd u, y, y_sim;     ///< the judged samples (after init)
  ResidualTests residual_tests;
  ResidualSpectrum spectrum;
  FrfComparison frf;
  std::optional<PoleZeroAnalysis> pole_zero;          ///< linear models only
  std::optional<TrainingHistory> history;             ///< when one was given or could be made
  std::optional<DistortionComparison> distortion;     ///< with a plant
  std::vector<double> distortion_amplitudes;          ///< the drive amplitudes of `distortion`
};

/// Analyses `model` on raw data (u, y) at the model's rate. `given_history` (e.g. from the model file or a
/// training log) is used as the training figure; without it a linear model's history is made by
/// spec.refine_iterations output-error iterations from the model. Throws std::invalid_argument for data too
/// short for init, the tests or a Welch segment, and whatever the computations throw.
ModelAnalysis analyze_model(const AnyModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                            const AnalysisSpec& spec, std::optional<TrainingHistory> given_history = std::nullopt);

/// A training history from JSON: an array of {"iter", "J_est_pct", "J_val_pct"?, "mode"?}, or an object
/// holding one as "history" (`identify narx` output) or "meta.history" (a model file). Returns nullopt when
/// `j` holds none; throws ConfigError naming `where` and the key for a malformed one.
std::optional<TrainingHistory> training_history_from_json(const nlohmann::json& j, const std::string& where);

/// The analysis as one JSON object (numbers and verdicts; spectra as arrays; no time series).
nlohmann::json analysis_to_json(const ModelAnalysis& a);

}  // namespace panelbass::models

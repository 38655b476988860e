#pragma once
// Training the neural feedback controller through the loop (fig. 7.10, Appendix 3): the controller N1
// drives the plant model N2 (NARX, or a neural state-space model: loop_plant.h), and θ1 is tuned so that the
// loop output tracks the desired output (the linear model behind the LQ feedforward controller). Gradients by
// dynamic backpropagation through N1 and the plant model (exact, the closed-loop form of [5L]; through an ss
// model's state recursion, forward sensitivities of its state), Levenberg–Marquardt steps, early stopping on
// validation data.
//
// The loss: V = 1/(2(N − skip))·Σ_{k≥skip} [w(k)·e(k)² + λ·p(k)² + μ·low(k)²] (w = 1 unless weights are
// given), with the tracking error e(k) = ŷ_s(k) − y_des(k)/y_scale (the plant model's scaled units; or the
// device's measured output in place of ŷ, FeedbackTrainingOptions::measure_est), the rail
// penalty p(k) = max(0, |s(k)| − knee) on the unlimited controller output s (time spent in the soft limit,
// i.e. near the rails) and the drive-offset penalty on low(k) = a·low(k−1) + (1 − a)·N1(k), N1's output
// through a one-pole low-pass at 5 Hz (a = e^{−2π·5/fs}; not in the thesis, see dc_penalty).

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <vector>

#include "models/control/neural_feedback.h"
#include "models/validation/performance.h"

namespace panelbass::models {

/// A device's output (raw units) for a drive `v` (raw units), as FeedbackTrainingOptions::measure_est plays it.
using DeviceOutput = std::function<Eigen::VectorXd(const Eigen::VectorXd& v)>;

/// A stretch of a record whose tracking error counts only through its harmonic series: the error there is
/// replaced by its least-squares fit with a mean and the sines and cosines of f, 2f, …, harmonics·f (those
/// below fs/2), so that what lies between the harmonics — a sensor's broadband noise — is left out. On a
/// stretch of L samples, white noise keeps (2·harmonics + 1)/L of its power.
struct HarmonicStretch {
  Eigen::Index start = 0, length = 0;  ///< its samples
  double f = 0.0;                      ///< fundamental, Hz
  int harmonics = 5;                   ///< the highest harmonic kept (evaluate analyses five)
};

/// One iteration's figures.
struct FeedbackTrainingRecord {
  int iteration = 0;
  double jc_est_pct = 0.0;     ///< [2C] J_c on the estimation data (plant model in the loop)
  double jc_val_pct = 0.0;     ///< [2C] J_c on the validation data (NaN without)
  double rail_fraction = 0.0;  ///< share of estimation samples with |s| above the knee
  int restart = 0;             ///< which training from fresh initial weights this is (design_feedback's restarts)
};

/// How training runs.
struct FeedbackTrainingOptions {
  int max_iterations = 40;         ///< LM iterations
  double rail_penalty = 10.0;      ///< λ of the rail penalty
  /// μ of the drive-offset penalty μ·low(k)², low = N1's output through a one-pole low-pass at 5 Hz: the
  /// plant's gain near DC is tiny (an accelerometer's is zero), so the tracking error cannot see an offset in
  /// the drive, and without this a controller settles on one (0.02 of full scale on panel-exciter's model,
  /// as large as the 160 Hz probe's drive) that a real coil turns into displacement and even harmonics.
  double dc_penalty = 1.0;
  Eigen::Index transient_skip = 50;  ///< samples left out of the loss at the start
  bool early_stopping = true;      ///< keep the parameters with the best validation J_c
  int patience = 10;               ///< iterations without validation improvement before stopping
  std::function<void(const FeedbackTrainingRecord&)> progress;  ///< called after every iteration
  /// Per-sample weights w(k) >= 0 of the tracking error on the estimation and validation records (empty = 1):
  /// the tracking terms become w(k)·e(k)², and J_c (the records' and early stopping's) is weighted alike.
  Eigen::VectorXd weight_est, weight_val;
  /// Tuning on the device: if set, each record's drive v is played into the device and the tracking error is
  /// its output against y_desired (J_c and early stopping are then the device's), while the Jacobian stays the
  /// plant model's along the same drive: in model mode the drive does not depend on the device's output, so
  /// the model's sensitivities are those of the loop as run, and the model only has to be right about how a
  /// change of drive moves the output, not about the distortion itself. Unset: the plant model's output
  /// (the thesis's). For the estimation and the validation record.
  DeviceOutput measure_est, measure_val;
  /// Stretches of the estimation and validation records whose error counts only through its harmonic series
  /// (HarmonicStretch; the loss, the Jacobian and J_c alike); elsewhere every sample's error counts as it is.
  std::vector<HarmonicStretch> harmonic_est, harmonic_val;
};

/// What training produced.
struct FeedbackTrainingResult {
  NeuralFeedback controller;                    ///< the kept parameters
  std::vector<FeedbackTrainingRecord> history;  ///< record 0 = the start
  int iterations = 0;
};

/// The first record of a training's history with the lowest validation J_c (the one early stopping kept);
/// null when no record has a finite one.
const FeedbackTrainingRecord* best_validation_record(const FeedbackTrainingResult& result);

/// The lowest validation J_c of a training's history, percent (infinity when none is finite).
double best_validation_jc_pct(const FeedbackTrainingResult& result);

/// `x` with each of `stretches` replaced by its least-squares fit with a mean and the stretch's harmonic
/// series (HarmonicStretch), at rate fs: what the tracking error counts there. Throws std::invalid_argument
/// naming a stretch that does not fit `x` (or is too short for its harmonics, or its f not within (0, fs/2)).
Eigen::VectorXd harmonic_series(const Eigen::VectorXd& x, const std::vector<HarmonicStretch>& stretches, double fs);

/// Small random weights for N1 (Mlp::initialize with `seed`) with the output layer scaled down by
/// `output_scale`, so the controller starts close to the identity but not at a symmetric saddle.
void initialize_feedback(NeuralFeedback& controller, std::uint64_t seed, double output_scale = 0.01);

/// The loss V above for feedforward output `u` (raw drive units) and desired output `y_desired` (raw); on
/// the `harmonic` stretches, the error's harmonic series only.
double feedback_loss(const NeuralFeedback& controller, const Eigen::VectorXd& u, const Eigen::VectorXd& y_desired,
                     double rail_penalty, Eigen::Index skip, const Eigen::VectorXd& weight = {},
                     double dc_penalty = 0.0, const std::vector<HarmonicStretch>& harmonic = {});

/// dV/dθ1 by dynamic backpropagation through the loop (Appendix 3 [1]/[2]): forward sensitivities of v
/// and ŷ, each the sum of the direct term and the terms through every fed-back past value.
Eigen::VectorXd feedback_gradient(const NeuralFeedback& controller, const Eigen::VectorXd& u,
                                  const Eigen::VectorXd& y_desired, double rail_penalty, Eigen::Index skip,
                                  const Eigen::VectorXd& weight = {}, double dc_penalty = 0.0,
                                  const std::vector<HarmonicStretch>& harmonic = {});

/// Trains `initial` by Levenberg–Marquardt on the exact closed-loop Jacobian. Throws std::invalid_argument
/// for mismatched lengths, non-finite data, records not longer than the skip or a harmonic stretch that does
/// not fit its record (or is too short for its harmonics, or its f not within (0, fs/2)).
FeedbackTrainingResult train_feedback(const NeuralFeedback& initial, const Eigen::VectorXd& u_est,
                                      const Eigen::VectorXd& y_desired_est, const Eigen::VectorXd& u_val,
                                      const Eigen::VectorXd& y_desired_val, const FeedbackTrainingOptions& options);

}  // namespace panelbass::models

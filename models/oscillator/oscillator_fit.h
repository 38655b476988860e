#pragma once
// Fitting an oscillator model (oscillator_model.h) to a record by its simulation error: a linear oscillator
// from the resonance of the record's ARX model (its poles mapped to continuous time), then Levenberg–Marquardt on the
// free-run error with the run's exact Jacobian, in warm-started stages that each free one more term of the
// restoring force (the input delay with the first), then the output and input taps; the initial state is
// fitted with the parameters. The stage whose validation J (by the protocol it is reported with: x(0) fitted
// to the first `init` outputs, J over the rest) is lowest is the model returned, with the terms up to it.

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "models/oscillator/oscillator_model.h"

namespace panelbass::models {

/// Where a fit is, for a progress display.
struct OscillatorFitProgress {
  std::string stage;    ///< "linear", a term's name, or "taps"
  std::size_t stage_number = 0;  ///< 0-based
  std::size_t stages = 1;        ///< how many the fit runs
  int iteration = 0;    ///< Levenberg–Marquardt iterations of this stage so far
  double j_est_pct = 0; ///< J on the estimation record along the fit, scaled units (x(0) fitted with θ, every sample)
};

/// How to fit.
struct OscillatorFitOptions {
  OscillatorStructure structure;  ///< the terms in the order their stages free them, substeps and taps
  bool delay = true;              ///< fit the input delay τ (freed with the first term, or with the taps)
  int max_iterations = 200;       ///< Levenberg–Marquardt iterations per stage
  Eigen::Index init = 50;         ///< measured outputs that set a record's state before its J
  /// Called after every iteration; returning false stops the fit (the best stage so far is kept).
  std::function<bool(const OscillatorFitProgress&)> progress;
};

/// One stage's outcome.
struct OscillatorStage {
  std::string name;        ///< as OscillatorFitProgress::stage
  int iterations = 0;      ///< accepted Levenberg–Marquardt steps
  double j_est_pct = 0.0;  ///< J on the estimation record by the protocol (x(0) from its first `init` outputs)
  double j_val_pct = 0.0;  ///< the same on the validation record (NaN without one)
  double seconds = 0.0;    ///< since the fit began
};

/// A fitted oscillator and how it got there.
struct OscillatorFit {
  OscillatorModel model;               ///< the chosen stage's, with the terms freed up to it
  std::vector<OscillatorStage> stages;
  std::size_t best_stage = 0;          ///< index into stages
};

/// Fits an oscillator to (u, y) at sample rate fs, choosing by (u_val, y_val) when given (else by the
/// estimation record). Throws std::invalid_argument for records of unequal length or shorter than
/// 4·(init + 10) samples, a bad structure, or data whose ARX models (orders 2 … 8) show no resonance.
OscillatorFit fit_oscillator(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const Eigen::VectorXd& u_val,
                             const Eigen::VectorXd& y_val, double fs, const OscillatorFitOptions& options);

}  // namespace panelbass::models

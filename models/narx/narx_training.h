#pragma once
// Training the NARX model (thesis ch. 5–6): PEM, OEM with the static gradient, OEM with dynamic
// backpropagation ([5L]/[5O]), OEM with a numerical gradient; steepest descent, a line search, or
// Levenberg–Marquardt; early stopping on validation data (fig. 6.4).

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "models/narx/narx_model.h"
#include "models/narx/narx_multiple_shooting.h"

namespace panelbass::models {

/// The thesis's four ways to compute the output and its gradient ([5N]/[5O]).
enum class TrainingMode {
  pem,    ///< series-parallel: measured past outputs; dŷ/dθ = ∂F/∂θ ([5K])
  oem_s,  ///< parallel, static gradient: ∂F/∂θ only (the approximation that fails, table 5.1)
  oem_d,  ///< parallel, dynamic backpropagation: ∂F/∂θ + Σ ∂F/∂ŷ(k−t)·dŷ(k−t)/dθ ([5L])
  oem_n,  ///< parallel, central finite differences of the simulation
  /// parallel, multiple shooting: windows simulated from free initial histories, continuity a penalty that
  /// tightens, θ and the histories stepped together by LM on exact gradients (narx_multiple_shooting); J and
  /// early stopping still by the free run over the whole record
  oem_ms,
};

/// Which iterations re-estimate the weight decay (TrainingOptions::evidence_decay).
enum class EvidenceDecay {
  off,           ///< D stays TrainingOptions::weight_decay
  all_modes,     ///< every LM iteration, PEM's included
  output_error,  ///< the output-error modes' iterations: PEM, the warm start, keeps weight_decay
};

/// "off", "all", "oem" → EvidenceDecay; throws std::invalid_argument.
EvidenceDecay parse_evidence_decay(const std::string& name);

/// How parameters are updated.
enum class Optimizer {
  sd,          ///< steepest descent θ ← θ − α·dV/dθ, updated every `batch` samples ([5C])
  linesearch,  ///< steepest descent with a backtracking/golden line search along −dV/dθ
  lm,          ///< Levenberg–Marquardt on the (exact, for oem_d) Jacobian of the simulation
};

/// "pem" → pem, "oem-s" → oem_s, "oem-d" → oem_d, "oem-n" → oem_n, "oem-ms" → oem_ms; throws
/// std::invalid_argument.
TrainingMode parse_training_mode(const std::string& name);
/// "pem", "oem-s", "oem-d", "oem-n", "oem-ms".
std::string to_string(TrainingMode mode);
/// "sd", "linesearch", "lm"; throws std::invalid_argument.
Optimizer parse_optimizer(const std::string& name);
/// "sd", "linesearch", "lm".
std::string to_string(Optimizer optimizer);

/// One iteration's figures.
struct TrainingRecord {
  int iteration = 0;
  TrainingMode mode = TrainingMode::pem;
  double j_est_pct = 0.0;   ///< simulation J on the estimation data (from TrainingOptions::init)
  double j_val_pct = 0.0;   ///< simulation J on the validation data (NaN without), likewise
  double j_val_weighted_pct = 0.0;  ///< Σw·e²/Σw·y² on the validation data with its weights (= j_val_pct
                                    ///< without): what early stopping watches
  double seconds = 0.0;     ///< since training started
  double weight_decay = 0.0;  ///< the D of the criterion the next iteration minimises (TrainingOptions::evidence_decay)
};

/// The weight decay both doors train with by Levenberg–Marquardt unless told otherwise: on the records of
/// bench/narx_recipes.sh it reached a lower validation J than none at little cost (docs/identification.md, issue 59).
inline constexpr double kDefaultLmWeightDecay = 0.01;

/// The default of TrainingOptions::pem_min_progress: the fraction measured best on bench/narx_recipes.sh.
inline constexpr double kDefaultPemMinProgress = 0.1;
/// Iterations over which TrainingOptions::pem_min_progress is judged.
inline constexpr int kPemProgressWindow = 10;

/// How training runs.
struct TrainingOptions {
  std::vector<TrainingMode> modes{TrainingMode::pem, TrainingMode::oem_d};  ///< run one after the other
  Optimizer optimizer = Optimizer::lm;
  int max_iterations = 100;          ///< per mode
  /// The prediction-error mode's own limit (−1: max_iterations): PEM's validation J creeps down long after the
  /// output-error mode would do better from where it is (docs/identification.md, issue 59)
  int pem_max_iterations = -1;
  /// The prediction-error mode also stops once its best validation J has fallen by less than this fraction over
  /// its last kPemProgressWindow iterations (0: off; needs validation data and early stopping), and the mode after
  /// it gets the iterations it left. PEM is the output-error mode's warm start: on bench/narx_recipes.sh's records
  /// its J_val creeps for tens of iterations that oem-d spends better, while a fixed short limit left the
  /// lightly damped A = 0.99 record a worse start (docs/identification.md, issue 59)
  double pem_min_progress = kDefaultPemMinProgress;
  double step = 0.1;                 ///< α for sd
  Eigen::Index batch = 0;            ///< L for sd: samples per update (0 = all, L = N)
  Eigen::Index transient_skip = -1;  ///< [5M] samples left out of the OEM loss; −1 = 2·(na + nb)
  /// Measured outputs that set the state of every simulation, estimation and validation alike, as
  /// `validate --init` does: ŷ(k) = y(k) for k < init, then free run. The loss leaves out at least these
  /// samples (skip = max(transient skip, init)), and with init > 0 the J figures of the history — and so
  /// early stopping and the kept model — are the J reported for the model, over k ≥ init. 0 = from rest
  /// (J over k ≥ skip, the thesis's protocol), which on a badly damped system a mid-record validation
  /// start drowns in its own transient.
  Eigen::Index init = 0;
  bool early_stopping = true;        ///< keep the parameters with the best validation J (fig. 6.4)
  int patience = 20;                 ///< iterations without improving the mode's best validation J before the mode stops
  /// Weight decay D ≥ 0 (NNSYSID's `D`, a scalar): LM and the line search minimise the regularised
  /// criterion W = V + D/(2·Σw)·‖θ‖² (w = 1: Σw = N − skip, so W = 1/(2(N−skip))·(Σ e² + D·θᵀθ)), the
  /// Gauss–Newton matrix gaining D/Σw on its diagonal. 0 = none; sd refuses D > 0. The J figures, and
  /// so early stopping, stay the unregularised ones.
  double weight_decay = 0.0;
  /// Re-estimate the weight decay after every Levenberg–Marquardt iteration by MacKay's evidence approximation
  /// (Bayesian regularisation: MacKay 1992; Foresee & Hagan 1997, MATLAB's trainbr), starting at weight_decay:
  /// D = γ·Σw·e² / ((Σw − γ)·‖θ‖²), γ = P − D·tr((JᵀJ + D·I)⁻¹) the effective number of parameters — the
  /// noise variance over the prior variance of the weights, so a noisy record gets a strong decay and a clean
  /// one almost none (docs/identification.md, issue 59). Only the free parameters count; the oem_ms and line
  /// search iterations keep the D they start with. Needs Optimizer::lm or linesearch.
  EvidenceDecay evidence_decay = EvidenceDecay::off;
  /// Which parameters train (size P; 1 = free, 0 = pruned); empty = all free. Pruned parameters are set to
  /// exactly 0 at the start and stay there: LM solves the reduced system over the free parameters (the
  /// pruned rows and columns of H and entries of g are zeroed), sd and the line search step along the
  /// masked gradient. Entries other than 0 and 1 throw std::invalid_argument.
  Eigen::VectorXd mask;
  /// Per-sample weights w(k) of the estimation loss (size N; finite, ≥ 0, a positive total after the
  /// skip); empty = 1. V = Σ w·e² / (2·Σ w), so scaling all weights changes nothing. The J figures
  /// reported stay the thesis's unweighted [2A]; std::invalid_argument for bad weights.
  Eigen::VectorXd weights;
  /// The same for the validation data; early stopping then watches Σw·e²/Σw·y² there. Empty = 1.
  Eigen::VectorXd validation_weights;
  /// oem_ms: the windows (from the transient skip on) and the continuity penalty; each oem_ms mode in the list
  /// starts afresh from the measured outputs as histories and this penalty. Needs Optimizer::lm.
  MultipleShootingOptions multiple_shooting;
  std::function<void(const TrainingRecord&)> progress;
};

/// What training produced.
struct TrainingResult {
  NarxModel model;                       ///< the kept parameters
  std::vector<TrainingRecord> history;   ///< record 0 = the start
  int iterations = 0;
  double seconds = 0.0;
};

/// Trains `initial` (scaled data: u, y already through model.scaling) with each mode in turn. Cost per
/// iteration is linear in N; LM accumulates JᵀJ (P×P) sample by sample, never storing N×P×P.
/// Throws std::invalid_argument for bad data (lengths, non-finite, too short for the structure).
TrainingResult train_narx(const NarxModel& initial, const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est,
                          const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, const TrainingOptions& options);

/// dV/dθ of V = 1/(2(N−skip))·Σ_{k≥skip} e(k)² for `mode` (scaled data; not oem_ms, whose loss has more than θ:
/// MultipleShooting), or with `weights` of
/// V = Σ w(k)·e(k)² / (2·Σ w(k)). For oem_n: central differences with step h. `init` as
/// TrainingOptions::init (the simulation's first init outputs measured; skip ≥ init, else invalid_argument).
Eigen::VectorXd loss_gradient(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                              TrainingMode mode, Eigen::Index skip, double h = 1e-6,
                              const Eigen::VectorXd& weights = Eigen::VectorXd(), Eigen::Index init = 0);

/// The Gauss–Newton matrix H = 1/(N−skip)·Σ_{k≥skip} ψ(k)·ψ(k)ᵀ, ψ = dŷ/dθ for `mode` (the matrix LM uses;
/// for oem_d the exact [5L] sensitivities of the simulation, for oem_n central differences). Scaled data.
/// With `weights`: 1/Σw·Σ w(k)·ψ(k)·ψ(k)ᵀ. `init` as loss_gradient's.
Eigen::MatrixXd gauss_newton_hessian(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                     TrainingMode mode, Eigen::Index skip,
                                     const Eigen::VectorXd& weights = Eigen::VectorXd(), Eigen::Index init = 0);

/// The loss V for `mode` (pem: prediction error; oem_*: simulation error, its state from `init` measured
/// outputs as loss_gradient says), weighted as loss_gradient says.
double training_loss(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                     TrainingMode mode, Eigen::Index skip, const Eigen::VectorXd& weights = Eigen::VectorXd(),
                     Eigen::Index init = 0);

}  // namespace panelbass::models

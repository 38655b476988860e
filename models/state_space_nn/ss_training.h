#pragma once
// Training of the neural state-space model (SUBNET): from the best linear model, Adam on mini-batches of
// truncated simulation windows with exact gradients, and the model kept whose validation J — the J the
// model reports, the first `init` measured samples setting its state — is lowest.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "models/linear/linear_model.h"
#include "models/optimization/adam.h"
#include "models/state_space_nn/ss_model.h"

namespace panelbass::models {

/// The starting model: `linear`'s balanced realisation (nx = its order) as A, B, C, D and its scaling, the
/// networks' last layers zero (so it simulates exactly as `linear`), and the encoder's affine part the
/// least-squares map from z(k) to the linear model's state along the raw estimation data u, y. Seeded.
SsModel ss_initial_model(const LinearModel& linear, SsStructure structure, const Eigen::VectorXd& u,
                         const Eigen::VectorXd& y, std::uint64_t seed);

/// Sets the encoder's affine part (E, c2) of `m` to the least-squares map from z(k) (and 1) to `states`
/// (nx × N, the model's state at every sample) along scaled data us, ys of N samples, past the first 2L.
/// Throws std::invalid_argument for mismatched sizes or N ≤ 3L.
void ss_fit_encoder(SsModel& m, const Eigen::VectorXd& us, const Eigen::VectorXd& ys, const Eigen::MatrixXd& states);

/// One epoch of training.
struct SsTrainingRecord {
  int epoch = 0;             ///< 0: the starting model
  double loss = 0.0;         ///< mean window loss over the epoch (scaled units²)
  double j_val_pct = 0.0;    ///< J of the selection data (validation, else estimation), `init` protocol
  double seconds = 0.0;      ///< since training started
};

/// How to train.
struct SsTrainingOptions {
  Eigen::Index window = 100;  ///< T: samples simulated per window
  Eigen::Index batch = 32;    ///< windows per Adam step
  int max_epochs = 100;       ///< an epoch draws as many windows as the data holds (N/T)
  int patience = 0;           ///< epochs without a better J before stopping (0: never)
  AdamOptions adam;           ///< the learning rate and moments
  double final_learning_rate = 0.0;  ///< > 0: the rate decays geometrically to this at max_epochs
  Eigen::Index init = 50;     ///< measured samples that set the state before J
  std::uint64_t seed = 1;     ///< window draws
  /// After each epoch; returning false stops training (a time budget, a stop signal).
  std::function<bool(const SsTrainingRecord&)> progress;
};

/// What training produced.
struct SsTraining {
  SsModel model;                          ///< the model of the lowest selection J whose free run is bounded
  std::vector<SsTrainingRecord> history;  ///< every epoch, the start first
  int best_epoch = 0;
  double j_val_pct = 0.0;                 ///< its selection J
  double seconds = 0.0;
  int status = 0;                         ///< polish_ss: liblbfgs's return code (why it stopped; 0 = converged)
  /// Set when no candidate's free run was bounded (ss_free_run_runaway): `model` is then the start, and
  /// this its runaway; a model file of it would not load.
  std::optional<Runaway> runaway;
};

/// The selection J of `m` on raw data u, y (the `init` protocol); +∞ when its free run overflows (a cubic
/// term run away), so that the candidate is passed over and training goes on.
double ss_selection_j(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init);

/// Keeps candidate `m` of selection J `j` in `out` (model, J, best_epoch = iteration, runaway cleared) when j is
/// finite and below the kept one's (any finite J while the kept one runs away) and its free run is bounded.
bool ss_keep_if_better(const SsModel& m, double j, int iteration, SsTraining& out);

/// A loss of the stacked vector z = [θ; …] (the model's parameters first, then whatever else is trained with
/// them), filling dV/dz when `gradient` is non-null; non-finite when a trial runs a simulation away.
using SsStackedLoss = std::function<double(const Eigen::VectorXd& z, Eigen::VectorXd* gradient)>;

/// The L-BFGS run of polish_ss and train_ss_shooting: liblbfgs (More–Thuente; backtracking to Wolfe's conditions
/// with the polynomial or cubic nodes, whose long trial steps run a window away) minimises `loss` from z0 for at
/// most `iterations`, with no gradient-norm stop; a runaway trial gets a finite loss far above the start's. Every
/// iterate's θ = z.head(P) is judged by its selection J on raw u_sel, y_sel (the `init` protocol) and the lowest
/// kept, the start (recorded first) included.
SsTraining ss_lbfgs(const SsModel& start, const Eigen::VectorXd& z0, const SsStackedLoss& loss,
                    const Eigen::VectorXd& u_sel, const Eigen::VectorXd& y_sel, Eigen::Index init, int iterations,
                    const std::function<bool(const SsTrainingRecord&)>& progress);

/// How to polish.
struct SsPolishOptions {
  Eigen::Index window = 100;  ///< T of the fixed windows tiling the estimation data
  int iterations = 100;       ///< L-BFGS iterations at most
  Eigen::Index init = 50;     ///< measured samples that set the state before J
  /// After each iteration; returning false stops.
  std::function<bool(const SsTrainingRecord&)> progress;
};

/// Polishes `start` by L-BFGS (liblbfgs, with its More–Thuente line search) on the full-batch loss of
/// windows of options.window samples tiling the raw estimation data u, y from sample `lags` on, keeping
/// the iterate of the lowest selection J (on u_val, y_val, or the estimation data when empty) whose free
/// run is bounded, the start included. Throws std::invalid_argument for data shorter than lags + window.
SsTraining polish_ss(const SsModel& start, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                     const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, const SsPolishOptions& options);

/// Trains `start` on raw estimation data (u, y), selecting on raw validation data (u_val, y_val; the
/// estimation data when empty) among the candidates (the start, each epoch's model) whose free run is
/// bounded. Throws std::invalid_argument for data shorter than lags + window or
/// mismatched lengths.
SsTraining train_ss(const SsModel& start, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                    const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, const SsTrainingOptions& options);

}  // namespace panelbass::models

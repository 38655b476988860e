#pragma once
// Multiple shooting for the neural state-space model (issue 59): the estimation record cut into consecutive
// windows, each simulated from its own free initial state, continuity between them and the encoder's reading
// of each window's start as penalties, and L-BFGS on θ and every initial state together with the exact
// gradient; the model judged and kept by the J it reports (the encoder from the first `init` validation
// samples, then free run), as every ss trainer.

#include <Eigen/Core>
#include <functional>

#include "models/state_space_nn/ss_gradients.h"
#include "models/state_space_nn/ss_model.h"
#include "models/state_space_nn/ss_training.h"

namespace panelbass::models {

/// The multiple-shooting loss of `m` on scaled data u, y over consecutive windows (windows.starts[w+1] =
/// windows.starts[w] + windows.length) started from the free states x0 (n × W):
/// V = (Σ_w Σ_t e_w(t)² + ρ·Σ_{w≥1} ‖x0_w − x_{w−1}(T)‖² + ρ·Σ_w ‖encoder(z_w) − x0_w‖²) / (W·T),
/// x_{w−1}(T) the state window w−1 ends in, encoder(z_w) the state the encoder reads at window w's start (so
/// that it learns the states the free ones settle on; the free run that judges the model starts from it).
/// With `gradient` non-null it receives dV/dθ (size P) and `state_gradient` (if non-null) dV/dx0, exact.
/// Throws std::invalid_argument for windows that leave the data or are not consecutive, x0 not n × W, ρ < 0.
double ss_shooting_loss(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, const SsWindows& windows,
                        const Eigen::MatrixXd& x0, double penalty, Eigen::VectorXd* gradient,
                        Eigen::MatrixXd* state_gradient);

/// How to train by multiple shooting.
struct SsShootingOptions {
  Eigen::Index window = 100;  ///< T: samples per window; the windows tile the estimation data from `lags` on
  double penalty = 1.0;       ///< ρ: a unit of continuity (or encoder) mismatch weighs as one sample's error
  int iterations = 100;       ///< L-BFGS iterations at most (≥ 1)
  Eigen::Index init = 50;     ///< measured samples that set the state before J
  /// After each iteration; returning false stops.
  std::function<bool(const SsTrainingRecord&)> progress;
};

/// Trains `start` by multiple shooting on raw estimation data u, y: the initial states start at the encoder's,
/// L-BFGS (liblbfgs, More–Thuente) steps θ and them together, and the iterate of the lowest selection J (on
/// u_val, y_val, or the estimation data when empty) whose free run is bounded is kept, the start included.
/// Throws std::invalid_argument for data shorter than lags + 2 windows or a bad option.
SsTraining train_ss_shooting(const SsModel& start, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                             const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, const SsShootingOptions& options);

}  // namespace panelbass::models

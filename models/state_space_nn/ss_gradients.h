#pragma once
// The loss of a batch of simulation windows of the neural state-space model and its exact gradient by
// back-propagation through the state recursion (truncated simulation, SUBNET's multiple shooting).

#include <Eigen/Core>
#include <functional>
#include <span>

#include "models/state_space_nn/ss_model.h"

namespace panelbass::models {

/// The windows of one batch: each starts at starts[b] (≥ 0; the encoder reads the samples before it) and
/// runs `length` samples.
struct SsWindows {
  std::span<const Eigen::Index> starts;
  Eigen::Index length = 0;
};

/// Mean squared simulation error (scaled units) of `m` over the windows of scaled data u, y, each started
/// by the encoder: V = Σ_b Σ_t (ŷ_b(t) − y(starts[b] + t))² / (B·T). With `gradient` non-null it receives
/// dV/dθ (size P), exact, by back-propagation through time. Throws std::invalid_argument for a window
/// that leaves the data or for u, y of different lengths.
double ss_window_loss(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, const SsWindows& windows,
                      Eigen::VectorXd* gradient);

/// A term of the loss on the windows' final states x_b(T) (n × B): returns its value and sets its gradient
/// (n × B) with respect to them (multiple shooting's continuity penalty).
using SsFinalStateTerm = std::function<double(const Eigen::MatrixXd& final_states, Eigen::MatrixXd& gradient)>;

/// The windows' loss as ss_window_loss, but each window b started from the given state x0.col(b) (n × B)
/// instead of the encoder, plus `final_term` (may be empty) of their final states. With `gradient` non-null it
/// receives dV/dθ (size P; the encoder's entries zero) and `state_gradient` (if non-null) dV/dx0 (n × B), exact.
/// Throws std::invalid_argument as ss_window_loss, or for x0 not n × B.
double ss_window_loss_from_states(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                  const SsWindows& windows, const Eigen::MatrixXd& x0, const SsFinalStateTerm& final_term,
                                  Eigen::VectorXd* gradient, Eigen::MatrixXd* state_gradient);

/// The encoder's x(k0) for each window (n × B) from the scaled data before it.
Eigen::MatrixXd ss_encoded_states(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                  const SsWindows& windows);

/// Adds to `gradient` (size P) the encoder's share of dV/dθ for the windows' x(k0) = encoder(z), given
/// dV/dx(k0) (n × B).
void ss_add_encoder_gradient(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                             const SsWindows& windows, const Eigen::MatrixXd& state_gradient, Eigen::VectorXd& gradient);

}  // namespace panelbass::models

#pragma once
// The loss of a batch of simulation windows of the neural state-space model and its exact gradient by
// back-propagation through the state recursion (truncated simulation, SUBNET's multiple shooting).

#include <Eigen/Core>
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

}  // namespace panelbass::models

#pragma once
// The one state-space step: a system and its state x, stepped sample by sample. models::simulate, the
// engine's StateSpaceStage and the tests' LinearStage all run it, so the three compute the same numbers.

#include <Eigen/Core>
#include <span>
#include <vector>

#include "models/linear/state_space.h"

namespace panelbass::models {

/// A SISO state-space system run one sample at a time: sized when made, then allocation-free.
class StateSpaceRunner {
 public:
  /// An empty system (no states, D = 0): step() returns 0.
  StateSpaceRunner() = default;
  /// `system` at state `x0` (zero when empty); throws std::invalid_argument naming the mismatch if A is
  /// not n×n, B or C not of length n, or x0 neither empty nor of length n.
  explicit StateSpaceRunner(StateSpace system, const Eigen::VectorXd& x0 = {});

  /// y(k) = C·x(k) + D·u(k), then x(k+1) = A·x(k) + B·u(k); returns y(k).
  double step(double u) noexcept {
    // y(k) = C·x(k) + D·u(k),  x(k+1) = A·x(k) + B·u(k)
    const double y = c_.dot(x_) + system_.D * u;
    next_.noalias() = system_.A * x_;
    next_ += system_.B * u;
    x_.swap(next_);
    return y;
  }
  /// out[k] = step(in[k]) over a block (`out` as long as `in`), allocation-free: the same recursion with the
  /// products written out over a padded copy of [A B] made in the constructor, the state held in registers
  /// for up to 16 states; within rounding of step() (the sums run in another order).
  void step_block(std::span<const double> in, std::span<double> out) noexcept;
  /// The state back to zero.
  void reset() noexcept { x_.setZero(); }

  /// The state x(k) before the next step.
  const Eigen::VectorXd& state() const { return x_; }
  /// The system.
  const StateSpace& system() const { return system_; }
  /// Number of states.
  int order() const { return system_.order(); }

 private:
  StateSpace system_;
  Eigen::VectorXd c_;  // Cᵀ, so the output is a dot product of two column vectors
  Eigen::VectorXd x_, next_;
  // step_block's copy: per column j < n, A's column j padded with zeros to stride_ rows, then B, then Cᵀ.
  std::vector<double> packed_;
  Eigen::Index stride_ = 0;
};

}  // namespace panelbass::models

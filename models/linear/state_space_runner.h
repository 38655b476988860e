#pragma once
// The one state-space step: a system and its state x, stepped sample by sample. models::simulate, the
// engine's LinearStage and its StateSpaceStage all run it, so the three compute the same numbers.

#include <Eigen/Core>
#include <span>
#include <vector>

#include "models/linear/state_space.h"

namespace panelbass::models {

/// How step_block() runs the recursion.
enum class BlockForm {
  as_given,  ///< in the system's own coordinates (a dense A: n multiply-adds per state per sample)
  modal,     ///< in modal coordinates where A has a well-conditioned real modal form (see StateSpaceRunner)
};

/// A SISO state-space system run one sample at a time: sized when made, then allocation-free.
class StateSpaceRunner {
 public:
  /// An empty system (no states, D = 0): step() returns 0.
  StateSpaceRunner() = default;
  /// `system` at state `x0` (zero when empty); throws std::invalid_argument naming the mismatch if A is
  /// not n×n, B or C not of length n, or x0 neither empty nor of length n. With BlockForm::modal and up to
  /// 16 states, step_block() runs A's real modal form z = T⁻¹x (2×2 blocks [σ ω; −ω σ] for complex pole
  /// pairs, real poles two to a pair) when T is well conditioned (κ(T) ≤ 100) and the two forms' impulse
  /// responses differ, summed, by ≤ 1e-13 of the response's own sum; otherwise, and for step(), as given.
  explicit StateSpaceRunner(StateSpace system, const Eigen::VectorXd& x0 = {},
                            BlockForm block_form = BlockForm::as_given);

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
  /// for up to 16 states; within rounding of step() (the sums run in another order). In the modal form
  /// (uses_modal_form()) the state is carried into modal coordinates and back once per block.
  void step_block(std::span<const double> in, std::span<double> out) noexcept;
  /// The state back to zero.
  void reset() noexcept { x_.setZero(); }

  /// The state x(k) before the next step.
  const Eigen::VectorXd& state() const { return x_; }
  /// The system.
  const StateSpace& system() const { return system_; }
  /// Number of states.
  int order() const { return system_.order(); }
  /// True when step_block() runs the modal form.
  bool uses_modal_form() const { return modal_pairs_ > 0; }

 private:
  StateSpace system_;
  Eigen::VectorXd c_;  // Cᵀ, so the output is a dot product of two column vectors
  Eigen::VectorXd x_, next_;
  // step_block's copy: per column j < n, A's column j padded with zeros to stride_ rows, then B, then Cᵀ.
  std::vector<double> packed_;
  Eigen::Index stride_ = 0;
  // step_block's modal form (modal_pairs_ > 0): per lane of the 2·pairs modal states, A's diagonal entry,
  // its entry coupling the lane to the other lane of its pair, T⁻¹B and C·T, then T⁻¹ (2·pairs × n) and T.
  int modal_pairs_ = 0;
  std::vector<double> modal_;
  Eigen::MatrixXd to_modal_, from_modal_;
  Eigen::VectorXd z_;  // the modal state during a block

  void prepare_modal_form();
};

}  // namespace panelbass::models

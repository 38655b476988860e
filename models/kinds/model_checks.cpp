#include "models/kinds/model_checks.h"

#include <cmath>

#include "models/linear/extended_precision.h"

namespace panelbass::models {

std::optional<double> unstable_lq_radius(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, const Eigen::VectorXd& L) {
  const Eigen::MatrixXd loop = A - B * L.transpose();
  const double radius = static_cast<double>(extended::spectral_radius(loop.cast<extended::Real>()));
  if (radius < 1.0) return std::nullopt;
  return radius;
}

std::optional<Runaway> closed_loop_runaway(const NeuralFeedback& c) {
  const ClosedLoopRun run = simulate_closed_loop(c, free_run_drive());
  return runaway(c.plant.scaling().scale_y(run.y));
}

}  // namespace panelbass::models

#include "models/optimization/levenberg_marquardt.h"

#include <algorithm>

namespace panelbass::models {

LevenbergMarquardt::LevenbergMarquardt(const LmSettings& settings, Eigen::Index parameters)
    : settings_(settings),
      lambda_(settings.initial_lambda),
      scale_(parameters),
      damped_(parameters, parameters),
      // Sized in place: copy-assigning a fresh LDLT would copy its not-yet-set ComputationInfo.
      ldlt_(parameters),
      delta_(parameters),
      candidate_(parameters) {}

void LevenbergMarquardt::prepare_damping(const Eigen::MatrixXd& H) {
  const auto diagonal = H.diagonal();
  switch (settings_.damping) {
    case LmDamping::relative_to_largest:
      scale_ = diagonal.cwiseMax(1e-12 * std::max(diagonal.maxCoeff(), 1e-300));
      break;
    case LmDamping::relative_to_mean:
      floor_ = 1e-9 * std::max(diagonal.mean(), 1e-300);
      ridge_ = 0.0;  // H_ii + (λ·(H_ii + floor) + 0) is H_ii + λ·(H_ii + floor) to the bit
      break;
    case LmDamping::relative_to_mean_with_ridge:
      floor_ = 1e-9 * std::max(diagonal.mean(), 1e-300);
      ridge_ = 1e-12 * (1.0 + diagonal.maxCoeff());
      break;
  }
}

void LevenbergMarquardt::solve_damped(const Eigen::MatrixXd& H, const Eigen::VectorXd& g, const Eigen::VectorXd& mask) {
  damped_ = H;
  if (settings_.damping == LmDamping::relative_to_largest) {
    // (H + λ·max(diag H, floor))·δ = g
    damped_.diagonal() += lambda_ * scale_;
  } else {
    // (H + λ·(diag H + floor) + ridge)·δ = g
    damped_.diagonal().array() += lambda_ * (H.diagonal().array() + floor_) + ridge_;
  }
  ldlt_.compute(damped_);
  delta_ = ldlt_.solve(g);
  if (mask.size() != 0) delta_.array() *= mask.array();  // exactly 0 where a parameter is held
}

}  // namespace panelbass::models

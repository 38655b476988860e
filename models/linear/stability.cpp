#include "models/linear/stability.h"

#include <cmath>
#include <complex>
#include <numbers>

namespace panelbass::models {

std::optional<UnstablePole> unstable_pole(const TransferFunction& tf, double fs) {
  const Eigen::VectorXcd poles = tf.poles();
  Eigen::Index worst = -1;
  for (Eigen::Index i = 0; i < poles.size(); ++i) {
    if (worst < 0 || std::abs(poles[i]) > std::abs(poles[worst])) worst = i;
  }
  if (worst < 0 || std::abs(poles[worst]) < 1.0) return std::nullopt;
  return UnstablePole{std::abs(poles[worst]), std::abs(std::arg(poles[worst])) * fs / (2.0 * std::numbers::pi)};
}

}  // namespace panelbass::models

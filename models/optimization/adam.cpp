#include "models/optimization/adam.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace panelbass::models {

Adam::Adam(Eigen::Index parameters, AdamOptions options)
    : options_(options), m_(Eigen::VectorXd::Zero(parameters)), v_(Eigen::VectorXd::Zero(parameters)) {}

void Adam::step(Eigen::Ref<Eigen::VectorXd> theta, const Eigen::VectorXd& gradient) {
  if (theta.size() != m_.size() || gradient.size() != m_.size()) {
    throw std::invalid_argument("Adam::step: " + std::to_string(m_.size()) + " parameters, got θ of " +
                                std::to_string(theta.size()) + " and a gradient of " + std::to_string(gradient.size()));
  }
  ++t_;
  // m ← β1·m + (1−β1)·g,  v ← β2·v + (1−β2)·g²,  θ ← θ − α·(m/(1−β1ᵗ)) / (√(v/(1−β2ᵗ)) + ε)
  m_ = options_.beta1 * m_ + (1.0 - options_.beta1) * gradient;
  v_ = options_.beta2 * v_ + (1.0 - options_.beta2) * gradient.cwiseAbs2();
  const double c1 = 1.0 - std::pow(options_.beta1, static_cast<double>(t_));
  const double c2 = 1.0 - std::pow(options_.beta2, static_cast<double>(t_));
  theta.array() -= options_.learning_rate * (m_.array() / c1) / ((v_.array() / c2).sqrt() + options_.epsilon);
}

}  // namespace panelbass::models

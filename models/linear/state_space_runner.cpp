#include "models/linear/state_space_runner.h"

#include <stdexcept>
#include <string>
#include <utility>

namespace panelbass::models {

StateSpaceRunner::StateSpaceRunner(StateSpace system, const Eigen::VectorXd& x0) : system_(std::move(system)) {
  check_shape(system_, "state-space runner");
  const Eigen::Index n = system_.order();
  if (x0.size() != 0 && x0.size() != n) {
    throw std::invalid_argument("state-space runner: initial state has " + std::to_string(x0.size()) +
                                " entries, the system has " + std::to_string(n) + " states");
  }
  c_ = system_.C.transpose();
  x_ = x0.size() == 0 ? Eigen::VectorXd::Zero(n) : x0;
  next_ = Eigen::VectorXd::Zero(n);
}

}  // namespace panelbass::models

#pragma once
// The simplest controller a chain's feedforward slot runs, for tests of the chain around it: an LQ feedforward
// file whose controller is the FIR u*(k) = u(k) + c·u(k−1).

#include <nlohmann/json.hpp>

#include "models/control/lq_feedforward.h"

namespace panelbass::testing_support {

/// An lq_feedforward file at `fs` whose controller is u*(k) = u(k) + c·u(k−1): one state, A = −c, B = 1, C = 1 and
/// L = −c, so that the loop A − B·L is 0 and u* = −L·x + u with x(k) = u(k−1). Its gain is 1 + c at DC and
/// |1 + c·e^{−jω}| at ω.
inline nlohmann::json fir_gain_controller(double c, double fs = 3000.0) {
  models::LqFeedforward ff;
  ff.plant.A = Eigen::MatrixXd::Constant(1, 1, -c);
  ff.plant.B = Eigen::VectorXd::Ones(1);
  ff.plant.C = Eigen::RowVectorXd::Ones(1);
  ff.L = Eigen::RowVectorXd::Constant(1, -c);
  ff.weights = {1.0, 0.0};
  ff.fs = fs;
  return models::lq_feedforward_to_json(ff);
}

}  // namespace panelbass::testing_support

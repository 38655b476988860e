#pragma once
// A linear model's frequency response H(e^{jω}) on a grid of frequencies, for plots and reports.

#include <Eigen/Core>

#include "models/linear/state_space.h"
#include "models/linear/transfer_function.h"

namespace panelbass::models {

/// H(e^{j2πf/fs}) of `ss` at each of `frequency_hz`.
Eigen::VectorXcd frequency_response(const StateSpace& ss, const Eigen::VectorXd& frequency_hz, double fs);

/// H(e^{j2πf/fs}) of `tf` (its delay included) at each of `frequency_hz`.
Eigen::VectorXcd frequency_response(const TransferFunction& tf, const Eigen::VectorXd& frequency_hz, double fs);

}  // namespace panelbass::models

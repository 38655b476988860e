#pragma once
// Argument checks shared by the polynomial-model estimators, with the messages they throw.

#include <Eigen/Core>
#include <string>

#include "models/linear/arx_estimator.h"

namespace panelbass::models {

/// "<method>(na=…, nb=…, nk=…)": the name an estimator's errors begin with.
std::string orders_name(const char* method, const ModelOrders& orders);

/// Throws EstimationError unless no order is negative and nb is at least 1.
void require_valid_orders(const ModelOrders& orders, const std::string& name);

/// Throws EstimationError unless u and y are equally long, finite, and u is not constant (nor empty).
void require_usable_record(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const std::string& name);

}  // namespace panelbass::models

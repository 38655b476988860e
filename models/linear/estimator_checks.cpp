#include "models/linear/estimator_checks.h"

#include <cmath>

#include "models/linear/estimation_error.h"

namespace panelbass::models {
namespace {

/// Throws EstimationError "<name>: the <what> has a non-finite value at sample k" at the first non-finite x(k).
void require_finite(const Eigen::VectorXd& x, const char* what, const std::string& name) {
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k])) {
      throw EstimationError(name + ": the " + what + " has a non-finite value at sample " + std::to_string(k));
    }
  }
}

}  // namespace

std::string orders_name(const char* method, const ModelOrders& orders) {
  return std::string(method) + "(na=" + std::to_string(orders.na) + ", nb=" + std::to_string(orders.nb) +
         ", nk=" + std::to_string(orders.nk) + ")";
}

void require_valid_orders(const ModelOrders& orders, const std::string& name) {
  if (orders.na < 0 || orders.nb < 0 || orders.nk < 0) throw EstimationError(name + ": orders must not be negative");
  if (orders.nb < 1) throw EstimationError(name + ": nb must be at least 1 (the model needs an input)");
}

void require_usable_record(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const std::string& name) {
  if (u.size() != y.size()) {
    throw EstimationError(name + ": the input has " + std::to_string(u.size()) + " samples but the output has " +
                          std::to_string(y.size()));
  }
  require_finite(u, "input", name);
  require_finite(y, "output", name);
  if (u.size() == 0 || u.maxCoeff() == u.minCoeff()) throw EstimationError(name + ": the input is constant");
}

}  // namespace panelbass::models

#pragma once
// ARX models by least squares: the prediction error method with an equation-error noise model.

#include <Eigen/Core>

#include "models/linear/transfer_function.h"

namespace panelbass::models {

/// Orders of a polynomial model: na poles, nb numerator coefficients, nk samples of input delay.
struct ModelOrders {
  int na = 2;
  int nb = 2;
  int nk = 0;
};

/// ARX fit: minimises Σ_k (A(q)y(k) − B(q)u(k))² over the samples whose regressors lie inside the
/// record, by QR least squares (never the normal equations). Throws EstimationError for non-finite or
/// mismatched data, a constant input, too few samples for the parameters, or a rank-deficient problem.
TransferFunction estimate_arx(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const ModelOrders& orders);

}  // namespace panelbass::models

#pragma once
// Zhu's asymptotic method (thesis fig. 4.5, [4B]).

#include <Eigen/Core>

#include "models/linear/arx_estimator.h"
#include "models/linear/oe_estimator.h"

namespace panelbass::models {

/// How Zhu's method runs.
struct ZhuOptions {
  int high_order = 0;   ///< order H of the high-order ARX; 0 = automatic (max(20, 3·na), capped by the data)
  OeOptions oe;
};

/// What Zhu's method produced.
struct ZhuResult {
  TransferFunction tf;               ///< the low-order model
  TransferFunction high_order;       ///< the high-order ARX model G^H = B^H/A^H
  OeResult oe;                       ///< the weighted output-error fit
};

/// [4B]: fit a high-order ARX model by least squares; filter the data with its A^H (u_f = A^H·u,
/// y_f = B^H·u); fit the low-order model by output error on (u_f, y_f), which minimises
/// ∫|G^H − Ĝ|²·Φ_u·|A^H|² dω, starting from an ARX fit of the filtered data (no prior model needed).
ZhuResult estimate_zhu(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const ModelOrders& orders,
                       const ZhuOptions& options = {});

}  // namespace panelbass::models

#include "models/linear/zhu_estimator.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "models/linear/estimation_error.h"
#include "models/linear/estimator_checks.h"

namespace panelbass::models {
namespace {

/// x_f(k) = Σ_{m=0}^{n} c_m·x(k−m−delay), from rest: an FIR filter, so nothing can go unstable.
Eigen::VectorXd fir_filter(const Eigen::VectorXd& c, Eigen::Index delay, const Eigen::VectorXd& x) {
  const Eigen::Index N = x.size();
  Eigen::VectorXd out = Eigen::VectorXd::Zero(N);
  for (Eigen::Index m = 0; m < c.size(); ++m) {
    const Eigen::Index shift = m + delay;
    if (shift >= N) break;
    out.tail(N - shift) += c[m] * x.head(N - shift);
  }
  return out;
}

}  // namespace

ZhuResult estimate_zhu(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const ModelOrders& orders,
                       const ZhuOptions& options) {
  const std::string name = orders_name("Zhu", orders);
  require_valid_orders(orders, name);
  if (options.high_order < 0) throw EstimationError(name + ": the high order must not be negative");
  require_usable_record(u, y, name);
  const Eigen::Index N = u.size();

  // H = max(20, 3·na), capped so that the ARX(H, H) has at most N/10 parameters (2H ≤ N/10).
  const int low = std::max(orders.na, orders.nb);
  int high = options.high_order;
  if (high == 0) {
    high = std::max(20, 3 * orders.na);
    high = static_cast<int>(std::min<Eigen::Index>(high, N / 20));
    if (high < low) {
      throw EstimationError(name + ": " + std::to_string(N) + " samples are too few for a high-order model of order " +
                            std::to_string(low) + " or more (at most N/20 = " + std::to_string(N / 20) + ")");
    }
  } else if (high < low) {
    throw EstimationError(name + ": the high order " + std::to_string(high) +
                          " must be at least the model's order " + std::to_string(low));
  }

  ZhuResult result;
  // Step 1 (PEM): G^H = B^H/A^H by least squares.
  try {
    result.high_order = estimate_arx(u, y, ModelOrders{high, high, orders.nk});
  } catch (const EstimationError& e) {
    // Typically noise-free data of a low-order system: every H above the true order is singular.
    throw EstimationError(name + ": the high-order step failed: " + e.what() +
                          " (data that fit an exact low-order model need no Zhu step: use ARX or OE, or a "
                          "smaller high_order)");
  }

  // Step 2: the data are replaced by what G^H says, seen through A^H:
  // u_f = A^H(q)·u, y_f = B^H(q)·u = G^H·u_f, so that an output-error fit of y_f on u_f minimises
  // [4B] V2 = ∫|G^H − Ĝ|²·Φu·|A^H|² dω.
  Eigen::VectorXd a_poly(high + 1);
  a_poly << 1.0, result.high_order.a;
  const Eigen::VectorXd u_f = fir_filter(a_poly, 0, u);
  const Eigen::VectorXd y_f = fir_filter(result.high_order.b, orders.nk, u);

  // Step 3: start from an ARX fit of the filtered data (no prior model), stabilised, then output error
  // with the first H samples (the FIR filters' start-up) left out of the loss.
  OeOptions oe = options.oe;
  oe.transient_skip = std::max<Eigen::Index>(oe.transient_skip, high);
  const TransferFunction start = stabilized(estimate_arx(u_f, y_f, orders), oe.stability_margin);
  result.oe = estimate_oe(u_f, y_f, start, oe);
  result.tf = result.oe.tf;
  return result;
}

}  // namespace panelbass::models

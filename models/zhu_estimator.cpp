#include "models/zhu_estimator.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "models/estimation_error.h"

namespace panelbass::models {
namespace {

std::string zhu_name(const ModelOrders& o) {
  return "Zhu(na=" + std::to_string(o.na) + ", nb=" + std::to_string(o.nb) + ", nk=" + std::to_string(o.nk) + ")";
}

void require_finite(const Eigen::VectorXd& x, const char* what, const std::string& name) {
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k])) {
      throw EstimationError(name + ": the " + what + " has a non-finite value at sample " + std::to_string(k));
    }
  }
}

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
  const std::string name = zhu_name(orders);
  if (orders.na < 0 || orders.nb < 0 || orders.nk < 0) throw EstimationError(name + ": orders must not be negative");
  if (orders.nb < 1) throw EstimationError(name + ": nb must be at least 1 (the model needs an input)");
  if (options.high_order < 0) throw EstimationError(name + ": the high order must not be negative");
  if (u.size() != y.size()) {
    throw EstimationError(name + ": the input has " + std::to_string(u.size()) + " samples but the output has " +
                          std::to_string(y.size()));
  }
  require_finite(u, "input", name);
  require_finite(y, "output", name);
  const Eigen::Index N = u.size();
  if (N == 0 || u.maxCoeff() == u.minCoeff()) throw EstimationError(name + ": the input is constant");

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

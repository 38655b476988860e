#include "models/control/root_locus.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace panelbass::models {
namespace {

constexpr double inf = std::numeric_limits<double>::infinity();

// Max pole radius of the closed loop, the quantity the gain search minimises.
double slowest_radius(const TransferFunction& g, double gain) { return closed_loop(g, gain).max_radius; }

}  // namespace

Eigen::VectorXd closed_loop_polynomial(const TransferFunction& g, double gain) {
  if (g.nk < 0) throw std::invalid_argument("root locus: nk must be >= 0, got " + std::to_string(g.nk));
  const int n = std::max(g.na(), g.nb() > 0 ? g.nk + g.nb() - 1 : 0);
  // z^n·(A(z⁻¹) + k·z^(−nk)·B(z⁻¹)) = Σ_j c_j·z^(n−j),  c_j = a_j + k·b_(j−nk),  a_0 = 1
  Eigen::VectorXd c = Eigen::VectorXd::Zero(n + 1);
  c[0] = 1.0;
  for (int i = 1; i <= g.na(); ++i) c[i] += g.a[i - 1];
  for (int j = 0; j < g.nb(); ++j) c[g.nk + j] += gain * g.b[j];
  return c;
}

ClosedLoop closed_loop(const TransferFunction& g, double gain) {
  if (!std::isfinite(gain)) throw std::invalid_argument("root locus: gain must be finite");
  if (!g.all_finite()) throw std::invalid_argument("root locus: the model has a non-finite coefficient");
  const Eigen::VectorXd c = closed_loop_polynomial(g, gain);
  ClosedLoop loop;
  loop.gain = gain;
  // (1 + k·b_0)·y(t) = … with nk = 0: no solution for y(t) when the leading coefficient vanishes.
  if (std::abs(c[0]) <= 1e-14 * c.cwiseAbs().maxCoeff()) {
    loop.max_radius = inf;
    loop.impulse_length = inf;
    return loop;
  }
  // Trailing zero coefficients are poles at exactly z = 0 (delays); the rest by the companion matrix, so
  // k = 0 reproduces TransferFunction::poles() bit for bit.
  Eigen::Index degree = c.size() - 1;
  while (degree > 0 && c[degree] == 0.0) --degree;
  const Eigen::VectorXcd roots = polynomial_roots(c.head(degree + 1));
  loop.poles = Eigen::VectorXcd::Zero(c.size() - 1);
  loop.poles.head(roots.size()) = roots;
  loop.max_radius = loop.poles.size() > 0 ? loop.poles.cwiseAbs().maxCoeff() : 0.0;
  loop.stable = loop.max_radius < 1.0;
  // |p|^t = 0.01  ⇒  t = ln(0.01)/ln|p|
  if (!loop.stable) {
    loop.impulse_length = inf;
  } else if (loop.max_radius == 0.0) {
    loop.impulse_length = 0.0;
  } else {
    loop.impulse_length = std::log(0.01) / std::log(loop.max_radius);
  }
  return loop;
}

std::vector<ClosedLoop> root_locus(const TransferFunction& g, const std::vector<double>& gains) {
  std::vector<ClosedLoop> locus;
  locus.reserve(gains.size());
  for (const double k : gains) locus.push_back(closed_loop(g, k));
  return locus;
}

std::vector<ClosedLoop> root_locus(const LinearModel& model, const std::vector<double>& gains) {
  // u_raw = r − k·y_raw with u_raw = u_offset + u_scale·u, y_raw = y_offset + y_scale·y
  // ⇒ u = r' − (k·y_scale/u_scale)·y in the model's units.
  const double to_scaled = model.scaling.y_scale / model.scaling.u_scale;
  std::vector<ClosedLoop> locus;
  locus.reserve(gains.size());
  for (const double k : gains) {
    locus.push_back(closed_loop(model.tf, k * to_scaled));
    locus.back().gain = k;
  }
  return locus;
}

ShortestImpulse shortest_impulse_gain(const TransferFunction& g, double k_min, double k_max, int grid_points) {
  if (!std::isfinite(k_min) || !std::isfinite(k_max) || !(k_max > k_min)) {
    throw std::invalid_argument("shortest impulse gain: need finite k_min < k_max, got [" + std::to_string(k_min) +
                                ", " + std::to_string(k_max) + "]");
  }
  if (grid_points < 3) {
    throw std::invalid_argument("shortest impulse gain: grid points must be >= 3, got " + std::to_string(grid_points));
  }
  ShortestImpulse result;
  const double step = (k_max - k_min) / (grid_points - 1);
  std::size_t best = 0;
  for (int i = 0; i < grid_points; ++i) {
    const double k = i == grid_points - 1 ? k_max : k_min + i * step;
    result.grid.push_back(closed_loop(g, k));
    if (result.grid.back().max_radius < result.grid[best].max_radius) best = result.grid.size() - 1;
  }

  // Golden-section search for min max_radius(k) between the best grid point's neighbours.
  double lo = result.grid[best == 0 ? 0 : best - 1].gain;
  double hi = result.grid[std::min(best + 1, result.grid.size() - 1)].gain;
  const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
  double x1 = hi - ratio * (hi - lo), x2 = lo + ratio * (hi - lo);
  double f1 = slowest_radius(g, x1), f2 = slowest_radius(g, x2);
  const double tolerance = 1e-9 * (k_max - k_min);
  while (hi - lo > tolerance) {
    if (f1 <= f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - ratio * (hi - lo);
      f1 = slowest_radius(g, x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + ratio * (hi - lo);
      f2 = slowest_radius(g, x2);
    }
  }
  const ClosedLoop refined = closed_loop(g, 0.5 * (lo + hi));
  result.best = refined.max_radius <= result.grid[best].max_radius ? refined : result.grid[best];
  return result;
}

}  // namespace panelbass::models

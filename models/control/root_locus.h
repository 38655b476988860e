#pragma once
// Root locus of constant-gain output feedback around a linear model from drive to acceleration, and the
// gain that makes the closed loop's impulse response shortest (thesis figs 4.2 and 4.12: feedback of the
// acceleration as a pre-stabilisation that shortens the badly damped plant's impulse response).

#include <Eigen/Core>
#include <vector>

#include "models/linear/linear_model.h"
#include "models/linear/transfer_function.h"

namespace panelbass::models {

/// The closed loop for one feedback gain.
struct ClosedLoop {
  double gain = 0.0;            ///< k in u = r − k·y (in the units of the transfer function it was given)
  Eigen::VectorXcd poles;       ///< roots of z^n·(A(z⁻¹) + k·z^(−nk)·B(z⁻¹)), n = max(na, nk + nb − 1)
  double max_radius = 0.0;      ///< the slowest pole's |z| (+inf when the loop is ill-posed)
  bool stable = false;          ///< every pole strictly inside the unit circle
  /// Samples for the slowest mode to decay to 1 % of its size: ln(0.01)/ln(max_radius), from the pole
  /// radius rather than a simulation (so it does not depend on which signal is watched or on residues);
  /// 0 when every pole is at the origin (a finite impulse response), +inf when unstable.
  double impulse_length = 0.0;
};

/// The closed-loop characteristic polynomial in z, [c_0, …, c_n] with c_j = a_j + k·b_(j−nk) (a_0 = 1).
Eigen::VectorXd closed_loop_polynomial(const TransferFunction& g, double gain);

/// Poles, stability and impulse length of y = G·u with u = r − k·y: (A + k·q^(−nk)·B)·y = q^(−nk)·B·r.
/// With nk = 0 and 1 + k·b_0 = 0 the loop is algebraic and ill-posed: no poles, unstable, infinite length.
ClosedLoop closed_loop(const TransferFunction& g, double gain);

/// closed_loop for each of `gains`.
std::vector<ClosedLoop> root_locus(const TransferFunction& g, const std::vector<double>& gains);

/// The same for a model file's LinearModel, with gains in raw units (drive per sensor unit): the model
/// works in scaled units, where the gain is k·y_scale/u_scale. The returned `gain` fields are the raw gains.
std::vector<ClosedLoop> root_locus(const LinearModel& model, const std::vector<double>& gains);

/// The gain in [k_min, k_max] with the shortest closed-loop impulse response.
struct ShortestImpulse {
  ClosedLoop best;                 ///< the closed loop at the minimising gain
  std::vector<ClosedLoop> grid;    ///< the grid searched before refining
};

/// Minimises max pole radius (so impulse length) over k: the best of `grid_points` evenly spaced gains,
/// refined by golden-section search between its grid neighbours to |Δk| ≤ 1e-9·(k_max − k_min). Throws
/// std::invalid_argument for k_max ≤ k_min, non-finite bounds or fewer than 3 grid points.
ShortestImpulse shortest_impulse_gain(const TransferFunction& g, double k_min, double k_max, int grid_points = 201);

}  // namespace panelbass::models

#pragma once
// The mirror filter's adaptation from the coil current alone (issue #56, as Klippel's controller with a current
// sensor only): a shadow of the gray-box model [M1]–[M3] (mirror_filter.h) runs on the drive the chain sends, its
// current is compared with the measured one, and a Kalman filter on four scales of the model — θ_R on the coil's
// resistance (its temperature), θ_B on Bl(x) in both equations (the magnet, the coil's rest position), θ_K on K(x)
// (the suspension: the resonance moves with it) and θ_N on every nonlinear coefficient (the shapes' scale) —
// follows the transducer as it drifts. Each scale is a random walk (θ_N's at 0.3 of the others' rate and spread: the
// current tells it from θ_K less well); the measurement is
//   [A1] i_k = î_k(θ) + n_k,  linearised as  i_k − î_k ≈ Σ_j g_{j,k}·(θ_j − θ̂_j),
// with g_j = ∂î/∂θ_j propagated by the model's linearisation along its trajectory (its sensitivity states
// ∂(i, x, v)/∂θ_j; the damping's friction slope and the inductance's share of the current's Jacobian left out):
//   [A2] δv⁺·(1 − h·c5/2) = δv·(1 + h·c5/2) + h·(M_x·δx + M_i·δi + ∂M/∂θ_j),  δx⁺ = δx + h·δv⁺,
//        δi⁺ = −(E_v·δv⁺ + ∂E_v/∂x·v⁺·δx⁺ − g_b·δj)/e_R' + ∂i⁺/∂θ_j|direct,  δj⁺ = p·δj + (1 − p)·δi⁺
// (M the acceleration of [M2], E_v the back-EMF factor of [M1], g_b and p the eddy-current branch's step — 0 and 1
// without one —, e_R' = E_L/h + e_R + g_b). Per sample: one model step, 4×4 sensitivity updates and a 4×4 covariance
// update; allocation-free.

#include <Eigen/Core>
#include <array>

#include "models/control/mirror_filter.h"

namespace panelbass::models {

/// The Kalman filter on θ_R, θ_B, θ_K, θ_N from the coil current. The model's observer settings must be enabled with
/// measurement = current.
class MirrorCurrentAdapter {
 public:
  /// The scales it adapts: resistance, force factor, stiffness, nonlinearity.
  static constexpr int kScales = 4;
  /// Drives kept for the current's lag (the lag + 1 back).
  static constexpr int kDrives = 8;
  /// Samples between two refreshes of the shadow model's coefficients from the scales.
  static constexpr int kRefresh = 8;

  /// An adapter at rest, every scale 1. Throws std::invalid_argument when the model's settings are not for the
  /// current, the lag is outside −1..6, or a noise, rate or spread is not positive (the rate ≥ 0).
  explicit MirrorCurrentAdapter(const MirrorModel& model);
  /// The drive the chain sends out now (what the transducer gets: the caller clamps it to full scale).
  void push_drive(double drive) noexcept;
  /// The coil current measured for the same sample: the shadow steps, [A1] updates the scales.
  void update(double measured_current) noexcept;
  /// Back to rest, every scale 1.
  void reset() noexcept;
  /// The scales θ_R, θ_B, θ_K, θ_N (the others 1).
  MirrorScales scales() const noexcept;
  /// The shadow model's current for the last measured sample.
  double predicted_current() const noexcept { return predicted_; }

 private:
  MirrorModel base_, model_;
  EddyStep eddy_;  // the eddy-current branch's step (no scale moves it)
  MirrorState state_;
  std::array<double, kDrives> drives_{};
  int newest_ = 0;
  Eigen::Matrix<double, kScales, 1> theta_;
  Eigen::Matrix<double, kScales, kScales> p_;
  std::array<std::array<double, 4>, kScales> sensitivity_{};  // ∂(i, x, v, j)/∂θ_q (j: the eddy branch's current)
  Eigen::Matrix<double, kScales, 1> q_;  // each scale's random walk per sample, squared
  double r_ = 1.0, predicted_ = 0.0;
  int since_refresh_ = 0;
};

}  // namespace panelbass::models

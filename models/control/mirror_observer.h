#pragma once
// The mirror filter's eyes: an extended Kalman filter on the gray-box exciter model of mirror_filter.h, with
// the sensor (the panel's acceleration, through the AD filter, noisy) as its measurement, that estimates the
// exciter's state and adapts the suspension's stiffness on line. A feedforward inverse is only as good as its
// model: near the main resonance a stiffness 20 % off puts the predicted motion out of phase with the real one,
// and the filter then adds distortion instead of removing it. Klippel's controllers adapt their parameters
// from a measurement; here the stiffness scale θ_K (multiplying K(x) = c6 + c7·x + c8·x², so the resonance
// moves and the nonlinear part keeps its shape), the force factor's scale θ_F (multiplying c0, the linear
// Bl/m) and the nonlinearity's scale θ_N (multiplying every nonlinear coefficient: Bl(x)'s and K(x)'s nonlinear
// parts, the reluctance force, friction, the back-EMF's nonlinear part) are states of the filter, driven by the
// prediction error of the sensor. θ_K and θ_F together fit the fundamental's gain and phase, so θ_N is left the
// harmonics. Per sample, allocation-free: fixed-size matrices.
//
// The sensor map is fitted from the identification record: [S1] y_k = Σ_{j<4} s_j·v_{k−j}, v in mm/s the
// record's velocity (displacement differences) — a gain, the AD filter's lag and the sampling instant in one
// FIR on the velocity.

#include <Eigen/Core>
#include <array>

#include "models/control/mirror_filter.h"

namespace panelbass::models {

/// The measurement model [S1] fitted to a record, and its residual (mostly the sensor's noise).
struct SensorMapFit {
  std::array<double, 4> taps{};  ///< s_0..s_3 of [S1], sensor units per mm/s
  double noise_rms = 0.0;        ///< rms of the fit's residual, sensor units
};

/// Fits [S1] by least squares to `displacement` (m) and the sensor's `measured` output at `fs`. Throws
/// std::invalid_argument naming the problem for columns of unequal length, fewer than 1000 samples or a
/// non-finite sample.
SensorMapFit fit_sensor_map(const Eigen::VectorXd& displacement, const Eigen::VectorXd& measured, double fs);

/// The observer's Jacobian ∂f/∂z by its structure: rows i, x, v_0 depend on (i, x, v_0, θ_K, θ_F, θ_N) alone (this
/// 3×6 block, columns in that order), the velocity history is a shift (v_j ← v_{j−1}) and the scales are held.
using MirrorJacobianBlock = Eigen::Matrix<double, 3, 6>;

/// The extended Kalman filter that estimates the exciter's state (current, displacement, velocity) and the scales
/// θ_K, θ_F, θ_N from the drive it is given and the sensor's output. The model's `observer` must be set.
class MirrorObserver {
 public:
  /// Velocity rows kept: the newest (the model runs delay + 1 samples ahead of the sensor) back to the oldest
  /// that [S1] reads; enough for a delay up to kMaxDelay.
  static constexpr int kHistory = 9;
  /// The largest drive delay the observer takes.
  static constexpr int kMaxDelay = kHistory - 5;
  /// Current, displacement, kHistory velocities (newest first), θ_K, θ_F, θ_N.
  static constexpr int kStates = 2 + kHistory + 3;
  using Vector = Eigen::Matrix<double, kStates, 1>;
  using Matrix = Eigen::Matrix<double, kStates, kStates>;

  /// [EKF] P ← F·P·Fᵀ for the F that `jacobian` and the shift structure make (about a tenth of the dense product's
  /// work); `scratch` holds F·P. Allocation-free.
  static void propagate(const MirrorJacobianBlock& jacobian, Matrix& p, Matrix& scratch) noexcept;

  /// An observer at rest, every scale 1. Throws std::invalid_argument when the model has no observer settings or its
  /// delay exceeds kMaxDelay.
  explicit MirrorObserver(const MirrorModel& model);
  /// Time update: the model stepped by the drive the chain sends out now ([M1]–[M3], θ_K held).
  void predict(double drive) noexcept;
  /// Measurement update with the sensor's output for the same sample ([S1]).
  void update(double measured) noexcept;
  /// Back to rest, every scale 1.
  void reset() noexcept;
  /// The stiffness scale θ_K.
  /// The scales θ_K, θ_F, θ_N.
  MirrorScales scales() const { return {z_[kStates - 3], z_[kStates - 2], z_[kStates - 1]}; }
  /// The estimated state at the newest row (delay + 1 samples ahead of the last measurement).
  MirrorState state() const { return {z_[0], z_[1], z_[2], past_}; }
  /// The sensor output the model predicts for the sample about to be measured.
  double predicted_measurement() const { return h_.dot(z_); }

 private:
  /// z advanced by one drive sample: [M1]–[M3] on (i, x, v_0) at the scales (the drive history past_), the
  /// velocity history shifted.
  void step_state(const Vector& z, double drive, Vector& out) const noexcept;

  MirrorModel model_;
  Vector z_, h_, q_, scratch_, base_, gain_;
  Matrix p_, fp_;
  MirrorJacobianBlock jacobian_;
  std::array<double, 3> past_{};  // drive_{k−1..k−3}, the model's A(z) history
  double r_ = 1.0;
};

}  // namespace panelbass::models

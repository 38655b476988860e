#include "models/control/mirror_observer.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace panelbass::models {
namespace {

constexpr double kObserverMmPerM = 1000.0;
constexpr int kObservedCurrent = 0, kObservedDisplacement = 1, kObservedVelocity = 2;
constexpr int kStiffnessScale = MirrorObserver::kStates - 3, kForceScale = MirrorObserver::kStates - 2,
              kNonlinearScale = MirrorObserver::kStates - 1;
// The scales are kept within these bounds (a model off by more than this is not one to adapt from).
constexpr double kObserverScaleMin = 0.4, kObserverScaleMax = 2.5;
// Finite-difference steps of the Jacobian, in each state's units (A, mm, mm/s, 1).
constexpr double kObserverStep[] = {1e-7, 1e-7, 1e-5};
constexpr double kObserverScaleStep = 1e-7;

void require_sensor_record(const Eigen::VectorXd& a, const Eigen::VectorXd& b, double fs, const char* what) {
  if (a.size() != b.size()) {
    throw std::invalid_argument(std::string(what) + ": the columns must have the same length (" +
                                std::to_string(a.size()) + ", " + std::to_string(b.size()) + ")");
  }
  if (a.size() < 1000) {
    throw std::invalid_argument(std::string(what) + ": at least 1000 samples are needed, got " + std::to_string(a.size()));
  }
  if (!(fs > 0.0)) throw std::invalid_argument(std::string(what) + ": fs must be > 0");
  for (Eigen::Index k = 0; k < a.size(); ++k) {
    if (!std::isfinite(a[k]) || !std::isfinite(b[k])) {
      throw std::invalid_argument(std::string(what) + ": sample " + std::to_string(k) + " is not finite");
    }
  }
}

}  // namespace

SensorMapFit fit_sensor_map(const Eigen::VectorXd& displacement, const Eigen::VectorXd& measured, double fs) {
  require_sensor_record(displacement, measured, fs, "sensor map fit");
  const Eigen::Index n = displacement.size();
  Eigen::VectorXd v = Eigen::VectorXd::Zero(n);  // [M3]: v_k = (x_k − x_{k−1})/h, mm/s
  for (Eigen::Index k = 1; k < n; ++k) v[k] = (displacement[k] - displacement[k - 1]) * kObserverMmPerM * fs;
  const Eigen::Index first = 4, rows = n - first;
  Eigen::MatrixXd a(rows, 4);
  for (Eigen::Index r = 0; r < rows; ++r) {
    for (int j = 0; j < 4; ++j) a(r, j) = v[first + r - j];
  }
  const Eigen::VectorXd b = measured.tail(rows);
  const Eigen::VectorXd s = a.colPivHouseholderQr().solve(b);  // [S1]
  SensorMapFit fit;
  for (int j = 0; j < 4; ++j) fit.taps[static_cast<std::size_t>(j)] = s[j];
  fit.noise_rms = std::sqrt((a * s - b).squaredNorm() / static_cast<double>(rows));
  return fit;
}

MirrorObserver::MirrorObserver(const MirrorModel& model) : model_(model) {
  const MirrorObserverSettings& o = model.observer;
  if (!o.enabled || o.measurement != MirrorMeasurement::sensor) {
    throw std::invalid_argument("mirror observer: the model has no observer settings (sensor map)");
  }
  if (model.delay < 0 || model.delay > kMaxDelay) {
    throw std::invalid_argument("mirror observer: a drive delay of " + std::to_string(model.delay) +
                                " samples exceeds the " + std::to_string(kMaxDelay) + " it takes");
  }
  if (model.eddy.present()) {
    // its state holds i, x and v only (the sensor's fit, fit_mirror_model, fits no branch)
    throw std::invalid_argument("mirror observer: the model has an eddy-current branch, which the observer does not follow");
  }
  if (!(o.sensor_noise > 0.0 && o.process_noise >= 0.0 && o.stiffness_rate >= 0.0 && o.stiffness_spread > 0.0 &&
        o.nonlinear_rate >= 0.0 && o.nonlinear_spread > 0.0 && o.force_rate >= 0.0 && o.force_spread > 0.0)) {
    throw std::invalid_argument("mirror observer: sensor noise and the spreads must be > 0, the rates >= 0");
  }
  // [S1] reads rows k..k−3 of the velocity; the newest row kept is k + delay + 1
  h_.setZero();
  for (int j = 0; j < 4; ++j) h_[kObservedVelocity + model.delay + 1 + j] = o.sensor_taps[static_cast<std::size_t>(j)];
  const double h = 1.0 / model.fs;
  q_.setZero();
  q_[kObservedVelocity] = std::pow(o.process_noise * h, 2);
  q_[kObservedDisplacement] = std::pow(o.process_noise * h * h, 2);
  q_[kStiffnessScale] = o.stiffness_rate * o.stiffness_rate;
  q_[kForceScale] = o.force_rate * o.force_rate;
  q_[kNonlinearScale] = o.nonlinear_rate * o.nonlinear_rate;
  r_ = o.sensor_noise * o.sensor_noise;
  reset();
}

void MirrorObserver::reset() noexcept {
  z_.setZero();
  past_ = {};
  z_[kStiffnessScale] = 1.0;
  z_[kForceScale] = 1.0;
  z_[kNonlinearScale] = 1.0;
  p_.setZero();
  p_(kForceScale, kForceScale) = model_.observer.force_spread * model_.observer.force_spread;
  p_(kStiffnessScale, kStiffnessScale) = model_.observer.stiffness_spread * model_.observer.stiffness_spread;
  p_(kNonlinearScale, kNonlinearScale) = model_.observer.nonlinear_spread * model_.observer.nonlinear_spread;
}

void MirrorObserver::step_state(const Vector& z, double drive, Vector& out) const noexcept {
  const MirrorModel m = with_scales(model_, {z[kStiffnessScale], z[kForceScale], z[kNonlinearScale]});
  MirrorState s{z[kObservedCurrent], z[kObservedDisplacement], z[kObservedVelocity], past_};
  step_mirror_model(m, s, drive);
  out[kObservedCurrent] = s.i;
  out[kObservedDisplacement] = s.x;
  out[kObservedVelocity] = s.v;
  for (int j = kHistory - 1; j >= 1; --j) out[kObservedVelocity + j] = z[kObservedVelocity + j - 1];
  out[kStiffnessScale] = z[kStiffnessScale];
  out[kForceScale] = z[kForceScale];
  out[kNonlinearScale] = z[kNonlinearScale];
}

void MirrorObserver::propagate(const MirrorJacobianBlock& jacobian, Matrix& p, Matrix& scratch) noexcept {
  constexpr int kShifted = kHistory - 1;
  // F·P: rows i, x, v_0 from the block on P's rows (i, x, v_0, θ…); the history's rows are P's one row up; the scales'
  // rows are P's
  Eigen::Matrix<double, 6, kStates> rows;
  rows << p.topRows<3>(), p.bottomRows<3>();
  scratch.topRows<3>().noalias() = jacobian * rows;
  scratch.middleRows<kShifted>(3) = p.middleRows<kShifted>(2);
  scratch.bottomRows<3>() = p.bottomRows<3>();
  // (F·P)·Fᵀ the same way on the columns
  Eigen::Matrix<double, kStates, 6> cols;
  cols << scratch.leftCols<3>(), scratch.rightCols<3>();
  p.leftCols<3>().noalias() = cols * jacobian.transpose();
  p.middleCols<kShifted>(3) = scratch.middleCols<kShifted>(2);
  p.rightCols<3>() = scratch.rightCols<3>();
}

void MirrorObserver::predict(double drive) noexcept {
  // [EKF] z⁻ = f(z, u), P⁻ = F·P·Fᵀ + Q, F = ∂f/∂z: by finite differences for (i, x, v_0 and the scales), a shift for the
  // velocity history
  step_state(z_, drive, base_);
  constexpr int kColumns[] = {kObservedCurrent, kObservedDisplacement, kObservedVelocity, kStiffnessScale, kForceScale,
                              kNonlinearScale};
  for (int j = 0; j < 6; ++j) {
    const int c = kColumns[j];
    const double step = j < 3 ? kObserverStep[j] : kObserverScaleStep;
    scratch_ = z_;
    scratch_[c] += step;
    step_state(scratch_, drive, gain_);
    jacobian_.col(j) = (gain_.head<3>() - base_.head<3>()) / step;
  }
  propagate(jacobian_, p_, fp_);
  p_.diagonal() += q_;
  z_ = base_;
  past_ = {drive, past_[0], past_[1]};
}

void MirrorObserver::update(double measured) noexcept {
  // [EKF] K = P⁻·hᵀ/(h·P⁻·hᵀ + r), z = z⁻ + K·(y − h·z⁻), P = P⁻ − K·h·P⁻
  scratch_.noalias() = p_ * h_;
  const double innovation_variance = h_.dot(scratch_) + r_;
  gain_ = scratch_ / innovation_variance;
  z_ += gain_ * (measured - h_.dot(z_));
  p_.noalias() -= gain_ * scratch_.transpose();
  p_ = 0.5 * (p_ + p_.transpose()).eval();
  z_[kStiffnessScale] = std::clamp(z_[kStiffnessScale], kObserverScaleMin, kObserverScaleMax);
  z_[kForceScale] = std::clamp(z_[kForceScale], kObserverScaleMin, kObserverScaleMax);
  z_[kNonlinearScale] = std::clamp(z_[kNonlinearScale], kObserverScaleMin, kObserverScaleMax);
  if (!z_.allFinite() || !p_.allFinite()) reset();  // a diverged estimate starts over from the model
}

}  // namespace panelbass::models

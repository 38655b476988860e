#include "models/control/mirror_current_adapter.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace panelbass::models {
namespace {

constexpr int kResistanceScale = 0, kForceFactorScale = 1, kStiffnessScale = 2, kNonlinearScale = 3;
// The scales are kept within these bounds (a model off by more than this is not one to adapt from).
constexpr double kAdapterScaleMin = 0.4, kAdapterScaleMax = 2.5;
// θ_N's random walk and initial spread relative to the other scales': the current tells the shapes' scale from K(x)'s
// less well than the linear scales (on a ±20 % variant of panel-exciter under an 80 Hz probe, θ_N at the full rate
// traded with θ_K and the 80 Hz cut fell to 8.0 / 14.5 / 22.5 dB; at 0.3 it is 19.4 / 23.1 / 31.4, docs/control.md).
constexpr double kShapeRelative = 0.3;

}  // namespace

MirrorCurrentAdapter::MirrorCurrentAdapter(const MirrorModel& model)
    : base_(model), model_(model), eddy_(eddy_step(model.eddy)) {
  const MirrorObserverSettings& o = model.observer;
  if (!o.enabled || o.measurement != MirrorMeasurement::current) {
    throw std::invalid_argument("mirror current adapter: the model's adaptation is not set for the coil current");
  }
  if (o.current_lag < -1 || o.current_lag > kDrives - 2) {
    throw std::invalid_argument("mirror current adapter: a current lag of " + std::to_string(o.current_lag) +
                                " samples is outside −1.." + std::to_string(kDrives - 2));
  }
  if (!(o.current_noise > 0.0 && o.scale_rate >= 0.0 && o.scale_spread > 0.0)) {
    throw std::invalid_argument("mirror current adapter: current_noise and scale_spread must be > 0, scale_rate >= 0");
  }
  r_ = o.current_noise * o.current_noise;
  const double q = o.scale_rate * o.scale_rate;
  q_ << q, q, q, kShapeRelative * kShapeRelative * q;
  reset();
}

void MirrorCurrentAdapter::reset() noexcept {
  state_ = {};
  drives_ = {};
  newest_ = 0;
  theta_.setOnes();
  const double spread = base_.observer.scale_spread;
  p_ = Eigen::Matrix<double, kScales, kScales>::Identity() * (spread * spread);
  p_(kNonlinearScale, kNonlinearScale) *= kShapeRelative * kShapeRelative;
  sensitivity_ = {};
  predicted_ = 0.0;
  since_refresh_ = 0;
  model_ = base_;
}

MirrorScales MirrorCurrentAdapter::scales() const noexcept {
  MirrorScales s;
  s.resistance = theta_[kResistanceScale];
  s.force_factor = theta_[kForceFactorScale];
  s.stiffness = theta_[kStiffnessScale];
  s.nonlinear = theta_[kNonlinearScale];
  return s;
}

void MirrorCurrentAdapter::push_drive(double drive) noexcept {
  newest_ = (newest_ + 1) % kDrives;
  drives_[static_cast<std::size_t>(newest_)] = drive;
}

void MirrorCurrentAdapter::update(double measured_current) noexcept {
  const MirrorModel& m = model_;
  const double h = 1.0 / m.fs;
  const std::array<double, 11>& c = m.mechanical;
  const std::array<double, 10>& e = m.electrical;
  // the measured current at k is the model's after the drive L + 1 samples back (the fit's alignment)
  const int back = base_.observer.current_lag + 1;
  const double drive = drives_[static_cast<std::size_t>((newest_ - back + kDrives) % kDrives)];
  const double i = state_.i, x = state_.x, v = state_.v;
  const double acceleration = step_mirror_model(m, eddy_, state_, drive);
  const double i1 = state_.i, x1 = state_.x, v1 = state_.v;

  // [A2]: the step's linearisation at this sample
  const double bl = c[0] + c[1] * x + c[2] * x * x;
  const double m_i = bl + 2.0 * (c[3] + c[4] * x) * i;
  const double m_x = (c[1] + 2.0 * c[2] * x) * i + c[4] * i * i + c[6] + 2.0 * c[7] * x + 3.0 * c[8] * x * x;
  const double spring = c[6] * x + c[7] * x * x + c[8] * x * x * x;
  // every term of [M2] but the linear ones (the step's acceleration less c0·i, the damping and c6·x: no second tanh)
  const double nonlinear_force = acceleration - c[0] * i - 0.5 * c[5] * (v + v1) - c[6] * x;
  const double over_lo = 1.0 / (1.0 - 0.5 * h * c[5]), hi = 1.0 + 0.5 * h * c[5];
  const double inductance = e[0] + e[1] * x1 + e[2] * x1 * x1 + e[3] * i * i;
  const double over_denominator = 1.0 / (inductance / h + e[4] + eddy_.resistance);
  const double emf = e[5] + e[6] * x1 + e[7] * x1 * x1 + e[8] * i + e[9] * i * x1;
  const double emf_x = e[6] + 2.0 * e[7] * x1 + e[9] * i;
  const double bl_emf = e[5] + e[6] * x1 + e[7] * x1 * x1;
  const double nonlinear_emf = e[6] * x1 + e[7] * x1 * x1 + e[8] * i + e[9] * i * x1;
  // each scale's direct effect on the acceleration and on the current (the coefficients it multiplies over it)
  const std::array<double, kScales> direct_force{0.0, bl * i / theta_[kForceFactorScale],
                                                 spring / theta_[kStiffnessScale],
                                                 nonlinear_force / theta_[kNonlinearScale]};
  const std::array<double, kScales> direct_current{-e[4] / theta_[kResistanceScale] * i1 * over_denominator,
                                                   -bl_emf / theta_[kForceFactorScale] * v1 * over_denominator, 0.0,
                                                   -nonlinear_emf / theta_[kNonlinearScale] * v1 * over_denominator};
  Eigen::Matrix<double, kScales, 1> g;
  const double eddy_g = eddy_.resistance, eddy_p = eddy_.pole;  // (locals: the stores below cannot alias them)
  for (std::size_t q = 0; q < kScales; ++q) {
    std::array<double, 4>& s = sensitivity_[q];  // δi, δx, δv, δj
    const double dv = (s[2] * hi + h * (m_x * s[1] + m_i * s[0] + direct_force[q])) * over_lo;
    const double dx = s[1] + h * dv;
    const double di = (inductance / h * s[0] - emf * dv - emf_x * v1 * dx + eddy_g * s[3]) * over_denominator + direct_current[q];
    s[0] = di;
    s[1] = dx;
    s[2] = dv;
    if (eddy_g != 0.0) s[3] = eddy_p * s[3] + (1.0 - eddy_p) * di;
    g[static_cast<Eigen::Index>(q)] = di;
  }

  // [A1]: the Kalman filter on the scales, each a random walk
  predicted_ = i1;
  p_.diagonal() += q_;
  const Eigen::Matrix<double, kScales, 1> pg = p_ * g;
  const double innovation = r_ + g.dot(pg);
  if (std::isfinite(innovation) && innovation > 0.0 && std::isfinite(measured_current)) {
    const Eigen::Matrix<double, kScales, 1> gain = pg / innovation;
    theta_ += gain * (measured_current - i1);
    p_.noalias() -= gain * pg.transpose();
    theta_ = theta_.cwiseMax(kAdapterScaleMin).cwiseMin(kAdapterScaleMax);
  }
  // the shadow's coefficients follow the scales every kRefresh samples (they move by a fraction of a percent meanwhile)
  if (++since_refresh_ >= kRefresh) {
    since_refresh_ = 0;
    model_ = with_scales(base_, scales());
    p_ = 0.5 * (p_ + p_.transpose());  // rounding kept from making P unsymmetric
  }
}

}  // namespace panelbass::models

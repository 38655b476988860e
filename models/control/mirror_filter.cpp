#include "models/control/mirror_filter.h"

#include <Eigen/Dense>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <stdexcept>
#include <string>

#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/model_header.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

constexpr const char* kMirrorFilterKind = "mirror_filter";
// The model's structure in files: 2 takes [M1]'s back-EMF at the end of the sample (1, before issue #34's last
// session, at its middle; such a file is refused rather than run with another meaning).
constexpr long kMirrorStructure = 2;
constexpr double kMmPerM = 1000.0;
// The smallest share of its rest value the filter lets the model's force factor Bl(x) fall to (the filter then asks
// at most 1/kMinForceShare times the reference's current for the force, and says it is saturated).
constexpr double kMinForceShare = 0.25;
// Friction velocity scales tried by the fit, mm/s.
constexpr double kFrictionVelocities[] = {5.0, 7.0, 10.0, 14.0, 20.0, 30.0, 50.0, 70.0, 100.0, 140.0, 200.0};

/// E_L and E_v of [M1] at (x, i).
struct Electrical {
  double inductance, back_emf;
};

Electrical electrical_terms(const std::array<double, 10>& e, double x, double i) noexcept {
  return {e[0] + e[1] * x + e[2] * x * x + e[3] * i * i, e[5] + e[6] * x + e[7] * x * x + e[8] * i + e[9] * i * x};
}

/// The force of [M2] without the current's terms: damping, K(x)·x, friction and Rms(v)'s rise, over the mass (v the velocity at
/// the sample instant).
double restoring(const std::array<double, 11>& c, double x, double v, double v0) noexcept {
  return c[5] * v + c[6] * x + c[7] * x * x + c[8] * x * x * x + c[9] * std::tanh(v / v0) + c[10] * v * v * v;
}

/// Least squares with each column scaled to unit norm first (the regressors differ by orders of magnitude);
/// returns the coefficients and writes the residual's squared norm.
Eigen::VectorXd scaled_least_squares(const Eigen::MatrixXd& a, const Eigen::VectorXd& b, double& residual) {
  Eigen::VectorXd scale = a.colwise().norm().transpose();
  for (Eigen::Index j = 0; j < scale.size(); ++j) {
    if (!(scale[j] > 0.0)) scale[j] = 1.0;  // a column that is zero in the record: its coefficient stays 0
  }
  const Eigen::MatrixXd as = a * scale.cwiseInverse().asDiagonal();
  Eigen::VectorXd theta = as.colPivHouseholderQr().solve(b);
  residual = (as * theta - b).squaredNorm();
  return theta.cwiseQuotient(scale);
}

/// One observer setting: its key, where it goes, and whether it must be > 0 (else >= 0); an absent key keeps the
/// default unless `required`.
void read_setting(JsonFields& f, const char* key, double& out, bool positive, bool required) {
  out = required ? f.number(key) : f.number(key, out);
  if (positive) {
    require_positive(out, f.path_of(key));
  } else {
    require_non_negative(out, f.path_of(key));
  }
}

/// The sensor observer's settings (mirror_observer.h): the map [S1] and its noises (the two noises the fit measured
/// are required).
void read_sensor_observer(JsonFields& f, MirrorObserverSettings& s) {
  const nlohmann::json* taps = f.member("sensor_taps");
  if (taps == nullptr) throw ConfigError(f.path_of("sensor_taps") + ": missing");
  const Eigen::VectorXd read = read_vector(*taps, f.path_of("sensor_taps"));
  if (read.size() != 4) throw ConfigError(f.path_of("sensor_taps") + ": 4 taps expected, got " + std::to_string(read.size()));
  for (int k = 0; k < 4; ++k) s.sensor_taps[static_cast<std::size_t>(k)] = read[k];
  read_setting(f, "sensor_noise", s.sensor_noise, true, true);
  read_setting(f, "process_noise_mm_per_s2", s.process_noise, false, true);
  read_setting(f, "stiffness_rate", s.stiffness_rate, false, false);
  read_setting(f, "stiffness_spread", s.stiffness_spread, true, false);
  read_setting(f, "force_rate", s.force_rate, false, false);
  read_setting(f, "force_spread", s.force_spread, true, false);
  read_setting(f, "nonlinear_rate", s.nonlinear_rate, false, false);
  read_setting(f, "nonlinear_spread", s.nonlinear_spread, true, false);
}

/// The adaptation from the coil current's settings (mirror_current_adapter.h).
void read_current_adaptation(JsonFields& f, MirrorObserverSettings& s) {
  s.measurement = MirrorMeasurement::current;
  s.current_lag = static_cast<int>(f.integer("current_lag", 0, -1, 6));
  read_setting(f, "current_noise_A", s.current_noise, true, true);
  read_setting(f, "scale_rate", s.scale_rate, false, false);
  read_setting(f, "scale_spread", s.scale_spread, true, false);
}

}  // namespace

bool minimum_phase(const std::array<double, 4>& a) {
  Eigen::Matrix3d companion = Eigen::Matrix3d::Zero();
  companion.row(0) << -a[1], -a[2], -a[3];
  companion(1, 0) = 1.0;
  companion(2, 1) = 1.0;
  return companion.eigenvalues().cwiseAbs().maxCoeff() < 0.95;
}

MirrorModel MirrorModel::linear() const {
  MirrorModel l = *this;
  for (int j : {1, 2, 3, 6, 7, 8, 9}) l.electrical[j] = 0.0;
  for (int j : {1, 2, 3, 4, 7, 8, 9, 10}) l.mechanical[j] = 0.0;
  return l;
}

EddyStep eddy_step(const MirrorEddyBranch& b) noexcept {
  if (!b.present()) return {};
  const double pole = std::exp(-b.rate);
  // (1 − e^{−ρ})/ρ → 1 as ρ → 0: expm1 keeps it exact for a slow branch
  return {b.resistance * -std::expm1(-b.rate) / b.rate, pole};
}

double step_mirror_model(const MirrorModel& m, MirrorState& s, double drive) noexcept {
  return step_mirror_model(m, eddy_step(m.eddy), s, drive);
}

double step_mirror_model(const MirrorModel& m, const EddyStep& eddy, MirrorState& s, double drive) noexcept {
  const double h = 1.0 / m.fs;
  const std::array<double, 11>& c = m.mechanical;
  // [M2] with the velocity at the sample instant, v̄ = (v_k + v_{k+1})/2: implicit in v_{k+1}, solved by Newton
  // (the damping, the friction and Rms(v) only take energy out, so the residual rises monotonically and the root is
  // unique)
  const double drive_force = (c[0] + c[1] * s.x + c[2] * s.x * s.x) * s.i + (c[3] + c[4] * s.x) * s.i * s.i +
                             c[6] * s.x + c[7] * s.x * s.x + c[8] * s.x * s.x * s.x;
  // without the friction and Rms(v) [M2] is linear in v_{k+1}: its root in closed form, Newton's start (the linear
  // reference has neither: the closed form is its step)
  double v1 = (s.v * (1.0 + 0.5 * h * c[5]) + h * drive_force) / (1.0 - 0.5 * h * c[5]);
  for (int it = 0; it < 50 && (c[9] != 0.0 || c[10] != 0.0); ++it) {
    const double mid = 0.5 * (s.v + v1), t = std::tanh(mid / m.friction_velocity);
    const double f = v1 - s.v - h * (drive_force + c[5] * mid + c[9] * t + c[10] * mid * mid * mid);
    const double df = 1.0 - h * 0.5 * (c[5] + c[9] * (1.0 - t * t) / m.friction_velocity + 3.0 * c[10] * mid * mid);
    const double step = f / df;
    v1 -= step;
    if (std::abs(step) <= 1e-15 * (1.0 + std::abs(v1))) break;
  }
  // [M1] solved for i_{k+1}, the back-EMF at x_{k+1}, v_{k+1}, the eddy-current branch's u_b = g·(i_{k+1} − j_k)
  const Electrical el = electrical_terms(m.electrical, s.x + h * v1, s.i);
  const std::array<double, 4>& a = m.drive_taps;
  const double w = a[0] * drive + a[1] * s.past[0] + a[2] * s.past[1] + a[3] * s.past[2];
  s.past = {drive, s.past[0], s.past[1]};
  double i1 = 0.0;
  if (const double g = eddy.resistance; g != 0.0) {
    i1 = (w - el.back_emf * v1 + el.inductance * s.i / h + g * s.eddy) / (el.inductance / h + m.electrical[4] + g);
    s.eddy = eddy.pole * s.eddy + (1.0 - eddy.pole) * i1;
  } else {
    i1 = (w - el.back_emf * v1 + el.inductance * s.i / h) / (el.inductance / h + m.electrical[4]);
  }
  const double accel = (v1 - s.v) / h;
  s.i = i1;
  s.v = v1;
  s.x += h * v1;  // [M3]
  return accel;
}

MirrorFilter::MirrorFilter(const MirrorModel& model)
    : base_(model), model_(model), reference_(model.linear()), eddy_(eddy_step(model.eddy)) {}

MirrorModel with_scales(MirrorModel model, const MirrorScales& scales) noexcept {
  std::array<double, 11>& c = model.mechanical;
  std::array<double, 10>& e = model.electrical;
  for (std::size_t j : {6u, 7u, 8u}) c[j] *= scales.stiffness;
  c[0] *= scales.force;
  for (std::size_t j : {1u, 2u, 3u, 4u, 7u, 8u, 9u, 10u}) c[j] *= scales.nonlinear;
  for (std::size_t j : {1u, 2u, 3u, 6u, 7u, 8u, 9u}) e[j] *= scales.nonlinear;
  e[4] *= scales.resistance;
  for (std::size_t j : {0u, 1u, 2u}) c[j] *= scales.force_factor;
  for (std::size_t j : {5u, 6u, 7u}) e[j] *= scales.force_factor;
  return model;
}

void MirrorFilter::set_scales(double stiffness, double force, double nonlinear) noexcept {
  MirrorScales scales;
  scales.stiffness = stiffness;
  scales.force = force;
  scales.nonlinear = nonlinear;
  set_scales(scales);
}

void MirrorFilter::set_scales(const MirrorScales& scales) noexcept {
  model_ = with_scales(base_, scales);
  // the linear reference: the scaled model's rest values (c0, c6, e_R, e5), the target following the transducer
  reference_.mechanical[0] = model_.mechanical[0];
  reference_.mechanical[6] = model_.mechanical[6];
  reference_.electrical[4] = model_.electrical[4];
  reference_.electrical[5] = model_.electrical[5];
}

void MirrorFilter::reset() noexcept {
  ref_ = {};
  current_ = 0.0;
  eddy_current_ = 0.0;
  past_ = {};
  saturated_ = false;
}

double MirrorFilter::process(double program) noexcept {
  const double h = 1.0 / model_.fs;
  step_mirror_model(reference_, eddy_, ref_, program);  // the reference at k+1
  const std::array<double, 11>& c = model_.mechanical;
  const std::array<double, 11>& r = reference_.mechanical;
  // the reference's velocity at k+2 (its [M2] is linear: v̄ = (v_{k+1} + v_{k+2})/2 solved in closed form)
  const double x1 = ref_.x, v1 = ref_.v;
  const double v2 = (v1 * (1.0 + 0.5 * h * r[5]) + h * (r[0] * ref_.i + r[6] * x1)) / (1.0 - 0.5 * h * r[5]);
  const double mid1 = 0.5 * (v1 + v2);
  // [M2] at k+1: the current ĩ that gives the nonlinear model the reference's acceleration,
  //   (c3 + c4·x)·ĩ² + (c0 + c1·x + c2·x²)·ĩ = (v_{k+2} − v_{k+1})/h − (the nonlinear model's restoring terms)
  const double qa = c[3] + c[4] * x1;
  // the force factor Bl(x)/m held at kMinForceShare of its rest value at least: where the fitted polynomial falls
  // further (or changes sign, beyond the record's displacements) its inverse would ask for an unbounded current
  double qb = c[0] + c[1] * x1 + c[2] * x1 * x1;
  saturated_ = false;
  if (c[0] != 0.0 && qb / c[0] < kMinForceShare) {
    qb = kMinForceShare * c[0];
    saturated_ = true;
  }
  const double qr = (v2 - v1) / h - restoring(c, x1, mid1, model_.friction_velocity);
  const double disc = qb * qb + 4.0 * qa * qr;
  double next = 0.0;
  if (disc >= 0.0 && qb != 0.0) {
    next = 2.0 * qr / (qb + std::copysign(std::sqrt(disc), qb));  // the root that tends to qr/qb as qa → 0
  } else {
    saturated_ = true;
    next = c[0] * ref_.i / (qb != 0.0 ? qb : c[0]);
  }
  // [M1] at k: the drive that takes the current from ĩ_k to ĩ_{k+1} at the reference's motion
  const Electrical el = electrical_terms(model_.electrical, x1, current_);
  double w = el.inductance * (next - current_) / h + model_.electrical[4] * next + el.back_emf * v1;
  if (const double g = eddy_.resistance; g != 0.0) {
    // the eddy-current branch's voltage for ĩ_{k+1}, and its current j moved on
    w += g * (next - eddy_current_);
    eddy_current_ = eddy_.pole * eddy_current_ + (1.0 - eddy_.pole) * next;
  }
  // the drive whose A(z)-filtered value is w: drive_k = (w − Σ_{j≥1} a_j·drive_{k−j}) / a_0
  const std::array<double, 4>& a = model_.drive_taps;
  const double drive = (w - a[1] * past_[0] - a[2] * past_[1] - a[3] * past_[2]) / a[0];
  current_ = next;
  if (!std::isfinite(drive)) {
    saturated_ = true;
    past_ = {};
    return program;
  }
  past_ = {drive, past_[0], past_[1]};
  return drive;
}

Eigen::VectorXd mirror_filter(const MirrorModel& model, const Eigen::VectorXd& program) {
  MirrorFilter filter(model);
  Eigen::VectorXd out(program.size());
  for (Eigen::Index k = 0; k < program.size(); ++k) out[k] = filter.process(program[k]);
  return out;
}

Eigen::VectorXd simulate_mirror_model(const MirrorModel& model, const Eigen::VectorXd& drive) {
  return run_mirror_model(model, drive).a;
}

bool run_mirror_model(const MirrorModel& model, const Eigen::VectorXd& drive, Eigen::Index lag, MirrorRun& out,
                      double current_bound) {
  const Eigen::Index n = drive.size();
  out.i.resize(n);
  out.x.resize(n);
  out.v.resize(n);
  out.a.resize(n);
  MirrorState s;
  const EddyStep eddy = eddy_step(model.eddy);
  for (Eigen::Index k = 0; k < n; ++k) {
    out.i[k] = s.i;
    out.x[k] = s.x;
    out.v[k] = s.v;
    const Eigen::Index at = k - lag;
    out.a[k] = step_mirror_model(model, eddy, s, at >= 0 && at < n ? drive[at] : 0.0);
    if (!(std::abs(s.i) < current_bound)) {
      for (Eigen::VectorXd* q : {&out.i, &out.x, &out.v, &out.a}) q->tail(n - k - 1).setConstant(std::nan(""));
      return false;
    }
  }
  return out.x.allFinite() && out.v.allFinite();
}

MirrorRun run_mirror_model(const MirrorModel& model, const Eigen::VectorXd& drive, Eigen::Index lag) {
  MirrorRun run;
  (void)run_mirror_model(model, drive, lag, run);
  return run;
}

MirrorFit fit_mirror_model(const Eigen::VectorXd& drive, const Eigen::VectorXd& current,
                           const Eigen::VectorXd& displacement, double fs, int max_delay, MirrorRecordKind kind) {
  const Eigen::Index n = drive.size();
  if (current.size() != n || displacement.size() != n) {
    throw std::invalid_argument("mirror fit: drive, current and displacement must have the same length (" +
                                std::to_string(n) + ", " + std::to_string(current.size()) + ", " +
                                std::to_string(displacement.size()) + ")");
  }
  if (n < 1000) throw std::invalid_argument("mirror fit: at least 1000 samples are needed, got " + std::to_string(n));
  if (!(fs > 0.0)) throw std::invalid_argument("mirror fit: fs must be > 0");
  if (max_delay < 0 || max_delay > 64) throw std::invalid_argument("mirror fit: max_delay must be within [0, 64]");
  for (Eigen::Index k = 0; k < n; ++k) {
    if (!std::isfinite(drive[k]) || !std::isfinite(current[k]) || !std::isfinite(displacement[k])) {
      throw std::invalid_argument("mirror fit: sample " + std::to_string(k) + " is not finite");
    }
  }
  const double h = 1.0 / fs;
  const Eigen::VectorXd x = displacement * kMmPerM;
  Eigen::VectorXd v = Eigen::VectorXd::Zero(n);  // [M3]: v_k = (x_k − x_{k−1})/h
  for (Eigen::Index k = 1; k < n; ++k) v[k] = (x[k] - x[k - 1]) / h;
  Eigen::VectorXd mid = Eigen::VectorXd::Zero(n);  // the velocity at the sample instant, (v_k + v_{k+1})/2
  for (Eigen::Index k = 0; k + 1 < n; ++k) mid[k] = 0.5 * (v[k] + v[k + 1]);
  const Eigen::VectorXd& i = current;
  // rows k = first..n−2 (each needs x_k, v_k, i_k, i_{k+1}, v_{k+1} and the drive max_delay samples back)
  const Eigen::Index first = 1 + max_delay + 3, rows = n - 1 - first;

  MirrorFit fit;
  fit.model.fs = fs;
  // [M2] for each friction velocity scale; the smallest residual wins
  Eigen::VectorXd accel(rows);
  Eigen::MatrixXd mech(rows, 11);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const Eigen::Index k = first + r;
    const double xk = x[k], ik = i[k];
    accel[r] = (v[k + 1] - v[k]) / h;
    mech.row(r) << ik, ik * xk, ik * xk * xk, ik * ik, ik * ik * xk, mid[k], xk, xk * xk, xk * xk * xk, 0.0,
        mid[k] * mid[k] * mid[k];
  }
  // a sampled plant: Numerov's weights on the rows (the model's docs), one row fewer at each end
  const bool sampled = kind == MirrorRecordKind::sampled_plant;
  const Eigen::Index used_rows = sampled ? rows - 2 : rows;
  const Eigen::VectorXd accel_target = sampled ? Eigen::VectorXd(accel.segment(1, used_rows)) : accel;
  Eigen::MatrixXd weighted(used_rows, 11);
  double best = std::numeric_limits<double>::infinity();
  for (double v0 : kFrictionVelocities) {
    for (Eigen::Index r = 0; r < rows; ++r) mech(r, 9) = std::tanh(mid[first + r] / v0);
    if (sampled) {
      weighted = (mech.topRows(used_rows) + 10.0 * mech.middleRows(1, used_rows) + mech.bottomRows(used_rows)) / 12.0;
    } else {
      weighted = mech;
    }
    double residual = 0.0;
    const Eigen::VectorXd c = scaled_least_squares(weighted, accel_target, residual);
    if (residual < best) {
      best = residual;
      fit.model.friction_velocity = v0;
      for (int j = 0; j < 11; ++j) fit.model.mechanical[static_cast<std::size_t>(j)] = c[j];
    }
  }
  // [2A] of the fit: the share of the acceleration's energy the best friction scale's regression misses
  fit.mechanical_fit_pct = j_ratio_percent(best, accel_target.squaredNorm(), "the record's acceleration");
  fit.mechanical_residual_rms = std::sqrt(best / static_cast<double>(used_rows));
  if (sampled && fit.model.mechanical[6] < 0.0) {
    // the one-step recursion's resonance put where the plant's is: 2 − 2·cos θ = −h²·c6 with θ = ω₀h
    const double wh = std::sqrt(-fit.model.mechanical[6]) * h;
    const double warp = (2.0 - 2.0 * std::cos(wh)) / (wh * wh);
    for (double& c : fit.model.mechanical) c *= warp;
  }

  // [M1] without the inductance (the coil's time constant, a fraction of a sample, and the DA filter's lag are
  // A(z)'s), solved for the current: i_{k+1} = (Σ_j a_j·drive_{k−d−j} − E_v(x_k, i_k)·v̄_k) / e_R, linear in
  // β_j = a_j/e_R and E_v's coefficients over e_R. The current is the regression's target and the drives its
  // inputs, so a band-limited drive that its own past predicts does not leak into A(z) (as it would with the
  // drive as the target). Each delay d and 1 to 4 taps are tried; the smallest residual wins among the A(z) that
  // are minimum phase (1/A(z) is how the filter inverts it), a longer A(z) only if it cuts the residual by 1 %.
  const double b1 = fit.model.mechanical[1] / fit.model.mechanical[0], b2 = fit.model.mechanical[2] / fit.model.mechanical[0];
  Eigen::MatrixXd regressors(rows, 7);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const Eigen::Index k = first + r;
    // [M1]'s back-EMF at the end of the sample: x_{k+1}, v_{k+1}
    const double xk = x[k + 1], ik = i[k], vk = v[k + 1];
    // the back-EMF's force factor has the shape Bl(x)/Bl0 = 1 + b1·x + b2·x² that [M2] found (one Bl for both
    // equations: the mechanical fit is the better determined one)
    regressors.block(r, 4, 1, 3) << -vk * (1.0 + b1 * xk + b2 * xk * xk), -ik * vk, -ik * xk * vk;
  }
  const Eigen::VectorXd target = current.segment(first + 1, rows);
  best = std::numeric_limits<double>::infinity();
  for (int d = 0; d <= max_delay; ++d) {
    for (int taps = 1; taps <= 4; ++taps) {
      for (int j = 0; j < taps; ++j) regressors.col(j) = drive.segment(first - d - j, rows);
      Eigen::MatrixXd used(rows, taps + 3);
      used << regressors.leftCols(taps), regressors.rightCols(3);
      double residual = 0.0;
      const Eigen::VectorXd beta = scaled_least_squares(used, target, residual);
      if (!(residual < 0.99 * best) || !(beta[0] != 0.0)) continue;
      std::array<double, 4> a{1.0, 0.0, 0.0, 0.0};
      for (int j = 1; j < taps; ++j) a[static_cast<std::size_t>(j)] = beta[j] / beta[0];
      if (!minimum_phase(a)) continue;
      best = residual;
      fit.model.delay = d;
      fit.model.drive_taps = a;
      fit.model.electrical = {};
      fit.model.electrical[4] = 1.0 / beta[0];  // e_R
      fit.model.electrical[5] = beta[taps] / beta[0];
      fit.model.electrical[8] = beta[taps + 1] / beta[0];
      fit.model.electrical[9] = beta[taps + 2] / beta[0];
    }
  }
  if (!std::isfinite(best)) throw std::invalid_argument("mirror fit: no electrical model the filter can invert fits the record");
  fit.model.electrical[6] = fit.model.electrical[5] * b1;
  fit.model.electrical[7] = fit.model.electrical[5] * b2;
  // [2A] of the fit: the share of the current's energy the chosen A(z) and back-EMF miss
  fit.electrical_fit_pct = j_ratio_percent(best, target.squaredNorm(), "the record's coil current");
  return fit;
}

nlohmann::json mirror_model_to_json(const MirrorModel& m, const nlohmann::json& meta) {
  nlohmann::json j = {{"format", kModelFormat},
          {"kind", kMirrorFilterKind},
          {"fs", m.fs},
          {"params",
           {{"electrical", m.electrical},
            {"mechanical", m.mechanical},
            {"friction_velocity_mm_per_s", m.friction_velocity},
            {"structure", kMirrorStructure},
            {"delay", m.delay},
            {"drive_taps", m.drive_taps}}},
          {"meta", meta.is_null() ? nlohmann::json::object() : meta}};
  if (m.eddy.present()) j["params"]["eddy"] = {{"resistance", m.eddy.resistance}, {"rate", m.eddy.rate}};
  if (m.observer.enabled && m.observer.measurement == MirrorMeasurement::current) {
    j["params"]["observer"] = {{"measurement", "current"},
                               {"current_lag", m.observer.current_lag},
                               {"current_noise_A", m.observer.current_noise},
                               {"scale_rate", m.observer.scale_rate},
                               {"scale_spread", m.observer.scale_spread}};
  } else if (m.observer.enabled) {
    j["params"]["observer"] = {{"sensor_taps", m.observer.sensor_taps},
                               {"sensor_noise", m.observer.sensor_noise},
                               {"process_noise_mm_per_s2", m.observer.process_noise},
                               {"stiffness_rate", m.observer.stiffness_rate},
                               {"stiffness_spread", m.observer.stiffness_spread},
                               {"force_rate", m.observer.force_rate},
                               {"force_spread", m.observer.force_spread},
                               {"nonlinear_rate", m.observer.nonlinear_rate},
                               {"nonlinear_spread", m.observer.nonlinear_spread}};
  }
  return j;
}

MirrorModel mirror_model_from_json(const nlohmann::json& j) {
  MirrorModel m;
  JsonFields top(j, "model");
  m.fs = read_model_header(top, kMirrorFilterKind);
  (void)read_model_meta(top);
  JsonFields p(read_model_params(top), "model.params");
  // `count` coefficients, or `count` − 1 where the last is optional (then 0)
  const auto coefficients = [&p](const char* key, auto& out, bool last_optional) {
    const nlohmann::json* v = p.member(key);
    if (v == nullptr) throw ConfigError(p.path_of(key) + ": missing");
    const Eigen::VectorXd read = read_vector(*v, p.path_of(key));
    const Eigen::Index count = static_cast<Eigen::Index>(out.size());
    if (read.size() != count && !(last_optional && read.size() == count - 1)) {
      throw ConfigError(p.path_of(key) + ": " + std::to_string(count) + " coefficients expected" +
                        (last_optional ? " (or " + std::to_string(count - 1) + ")" : "") + ", got " +
                        std::to_string(read.size()));
    }
    out.fill(0.0);
    for (Eigen::Index k = 0; k < read.size(); ++k) out[static_cast<std::size_t>(k)] = read[k];
  };
  if (p.member("structure") == nullptr || p.integer("structure", 0, 0, 1000) != kMirrorStructure) {
    throw ConfigError(p.path_of("structure") + ": " + std::to_string(kMirrorStructure) +
                      " expected (a mirror filter fitted by an older panelbass: fit it again with `design mirror`)");
  }
  coefficients("electrical", m.electrical, false);
  coefficients("mechanical", m.mechanical, true);
  m.friction_velocity = p.number("friction_velocity_mm_per_s");
  require_positive(m.friction_velocity, "model.params.friction_velocity_mm_per_s");
  m.delay = static_cast<int>(p.integer("delay", 0, 0, 64));
  if (const nlohmann::json* taps = p.member("drive_taps")) {
    const Eigen::VectorXd read = read_vector(*taps, p.path_of("drive_taps"));
    if (read.size() != 4 || read[0] != 1.0) {
      throw ConfigError(p.path_of("drive_taps") + ": 4 taps expected, the first 1");
    }
    for (int k = 0; k < 4; ++k) m.drive_taps[static_cast<std::size_t>(k)] = read[k];
    if (!minimum_phase(m.drive_taps)) {
      throw ConfigError(p.path_of("drive_taps") + ": A(z) must be minimum phase (roots inside |z| < 0.95)");
    }
  }
  if (const nlohmann::json* b = p.member("eddy")) {
    // the eddy-current branch (absent in a file written before issue #56's fourth session: none)
    JsonFields f(*b, p.path_of("eddy"));
    m.eddy.resistance = f.number("resistance");
    require_positive(m.eddy.resistance, f.path_of("resistance"));
    m.eddy.rate = f.number("rate");
    require_positive(m.eddy.rate, f.path_of("rate"));
    f.finish();
  }
  if (const nlohmann::json* o = p.member("observer")) {
    JsonFields f(*o, p.path_of("observer"));
    MirrorObserverSettings& s = m.observer;
    s.enabled = true;
    const std::string measurement = f.string("measurement", "sensor");
    if (measurement != "sensor" && measurement != "current") {
      throw ConfigError(f.path_of("measurement") + ": \"sensor\" or \"current\" expected, got \"" + measurement + "\"");
    }
    if (measurement == "current") {
      read_current_adaptation(f, s);
    } else {
      read_sensor_observer(f, s);
      if (m.delay > 4) throw ConfigError(p.path_of("delay") + ": the observer takes a drive delay up to 4 samples");
      if (m.eddy.present()) throw ConfigError(p.path_of("eddy") + ": the sensor's observer takes no eddy-current branch");
    }
    f.finish();
  }
  p.finish();
  top.finish();
  const double denominator = m.electrical[0] * m.fs + m.electrical[4];
  if (!(std::abs(denominator) > 0.0) || !(m.mechanical[0] != 0.0)) {
    throw ConfigError("model.params: electrical e0·fs + e4 and mechanical c0 must not be zero (no current, no force)");
  }
  return m;
}

}  // namespace panelbass::models

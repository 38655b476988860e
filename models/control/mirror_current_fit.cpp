#include "models/control/mirror_current_fit.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "models/optimization/least_squares.h"
#include "models/optimization/levenberg_marquardt.h"

namespace panelbass::models {
namespace {

// The output-error fit's parameters θ, each of order one: the linear ones as log-factors of the linear start, the
// nonlinear ones relative to the linear coefficient they modify (x in rms units, i over its rms). Left out (zero):
// the coil's rest inductance e0 (A(z) takes the time constant, as in fit_mirror_model; fitted, e0 went negative), c4
// and e9. Bl(x)'s asymmetry b1 is fitted last and kept only when it cuts the current's J_val by 10 % (on a symmetric
// Bl the current does not tell it from K(x)'s asymmetry: panel-exciter's 80 Hz cut fell 22 → 18 dB with it; on the
// docs' variant, b1 = 0.05, it rose −3 → 20 dB). The mechanical resistance's rise with velocity, Rms(v) = Rms·(1 +
// r2·v²), is fitted the same way, before b1, and kept on the same terms: a free r2 beside the friction's tanh (both odd
// in v) would trade with it on a transducer without Rms(v). The inductance's slope dLe/dx is one
// parameter, λ = (dLe/dx)/Bl0, that sets the three terms it makes, as the coil's magnetic energy ½·Le(x)·i² has them:
// the flux's change Le(x)·di/dt (e1 = λ·e5, with e0 = 0: its rest value is A(z)'s), the back-EMF i·v·dLe/dx
// (e8 = λ·e5) and the reluctance force ½·i²·dLe/dx (c3 = ½·λ·c0). With e1 left out and c3 free (before issue #56's
// second session) the fit put the missing Le(x)·di/dt into c3 (31 % low on panel-exciter) and K(x) (k2 13 % low), and
// the 80 Hz cut stopped at 12.7 dB (docs/control.md, the oracle table).
enum CurrentFitParameter : Eigen::Index {
  kResistance, kBackEmf, kDamping, kStiffness, kTap1, kTap2, kTap3,  // e_R, e5, c5, c6 (log), a1..a3
  kForceFactor2,                  // Bl(x)/Bl0 = 1 + b2·x² in [M1] and [M2] alike
  kStiffness1, kStiffness2,       // c7, c8 over c6
  kFriction,                      // c9 over c0·i_rms
  kInductanceSlope,               // λ = (dLe/dx)/Bl0 times i_rms: e1 = e8 = λ·e5, c3 = ½·λ·c0
  kFrictionVelocity,              // log of v0 over its start
  kInductanceCurrent,             // Le(i)'s e3 over e_R·h/i_rms²
  kDampingRise,                   // r2·v_rms² of Rms(v): c10 = c5·r2 (kept only when it earns its place)
  kForceFactor1,                  // Bl(x)'s asymmetric b1 in [M1] and [M2] alike (kept only when it earns its place)
  kCurrentFitParameters
};
constexpr Eigen::Index kLinearParameters = kTap3 + 1;
constexpr double kFrictionVelocityRange = 5.0;  // |log(v0 / its start)| at most: v0 within ×/÷ 148 of a fifth of v_rms

/// The scales θ is relative to: the record's current and the linear start's velocity, rms.
struct CurrentFitScales {
  double current_rms = 1.0, velocity_rms = 1.0;
};

/// The model θ stands for, around the linear start `start` (c0 fixed: it sets the scale of x).
MirrorModel current_fit_model(const MirrorModel& start, const Eigen::VectorXd& theta, const CurrentFitScales& scales) {
  const double current_rms = scales.current_rms;
  MirrorModel m = start;
  std::array<double, 10>& e = m.electrical;
  std::array<double, 11>& c = m.mechanical;
  e = {};
  e[4] = start.electrical[4] * std::exp(theta[kResistance]);
  e[5] = start.electrical[5] * std::exp(theta[kBackEmf]);
  c[5] = start.mechanical[5] * std::exp(theta[kDamping]);
  c[6] = start.mechanical[6] * std::exp(theta[kStiffness]);
  m.drive_taps = {1.0, theta[kTap1], theta[kTap2], theta[kTap3]};
  for (int j : {1, 2, 3, 4, 7, 8, 9, 10}) c[static_cast<std::size_t>(j)] = 0.0;
  if (theta.size() == kLinearParameters) return m;
  const double b2 = theta[kForceFactor2];
  c[2] = c[0] * b2;
  e[7] = e[5] * b2;
  c[7] = c[6] * theta[kStiffness1];
  c[8] = c[6] * theta[kStiffness2];
  c[9] = c[0] * current_rms * theta[kFriction];
  const double slope = theta[kInductanceSlope] / current_rms;  // λ
  e[1] = e[5] * slope;
  e[8] = e[5] * slope;
  c[3] = 0.5 * c[0] * slope;
  // v0 held within e^±kFrictionVelocityRange of its start: with no friction in the record it has nothing to fit, and
  // its θ would otherwise walk off to an infinite v0
  m.friction_velocity =
      start.friction_velocity * std::exp(std::clamp(theta[kFrictionVelocity], -kFrictionVelocityRange, kFrictionVelocityRange));
  e[3] = e[4] / m.fs * theta[kInductanceCurrent] / (current_rms * current_rms);
  c[10] = c[5] * theta[kDampingRise] / (scales.velocity_rms * scales.velocity_rms);
  c[1] = c[0] * theta[kForceFactor1];
  e[6] = e[5] * theta[kForceFactor1];
  return m;
}

/// θ of `m` around itself as the start (current_fit_model's inverse with start = m): the linear log-factors 0, A(z)'s
/// taps and the nonlinear coefficients m's own.
Eigen::VectorXd theta_of(const MirrorModel& m, const CurrentFitScales& scales) {
  const std::array<double, 10>& e = m.electrical;
  const std::array<double, 11>& c = m.mechanical;
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(kCurrentFitParameters);
  for (int j = 1; j <= 3; ++j) theta[kTap1 + j - 1] = m.drive_taps[static_cast<std::size_t>(j)];
  theta[kForceFactor2] = c[2] / c[0];
  theta[kStiffness1] = c[7] / c[6];
  theta[kStiffness2] = c[8] / c[6];
  theta[kFriction] = c[9] / (c[0] * scales.current_rms);
  theta[kInductanceSlope] = e[5] != 0.0 ? e[1] / e[5] * scales.current_rms : 0.0;
  theta[kInductanceCurrent] = e[3] * m.fs * scales.current_rms * scales.current_rms / e[4];
  theta[kDampingRise] = c[5] != 0.0 ? c[10] * scales.velocity_rms * scales.velocity_rms / c[5] : 0.0;
  theta[kForceFactor1] = c[1] / c[0];
  return theta;
}

/// The record's drive, current and sensor with the fit's split and lags.
struct CurrentFitRecord {
  const Eigen::VectorXd& drive;
  const Eigen::VectorXd& current;
  const Eigen::VectorXd& sensor;  // empty: none
  MirrorSensorKind sensor_kind;
  Eigen::Index fit_end;   // samples [0, fit_end) are fitted, [fit_end, n) validate
  int lag = 0;            // L
  int sensor_delay = 0;   // D
};

/// Runs `m` free over the record (mirror_filter.h); false if it leaves the finite (or blows up past 1e6 times the
/// current's peak).
bool run_current_model(const MirrorModel& m, const CurrentFitRecord& r, double current_peak, MirrorRun& out) {
  return run_mirror_model(m, r.drive, r.lag, out, 1e6 * current_peak);
}

/// The sensor's quantity q from a run.
const Eigen::VectorXd& sensed_quantity(const MirrorRun& run, MirrorSensorKind kind) {
  switch (kind) {
    case MirrorSensorKind::velocity: return run.v;
    case MirrorSensorKind::displacement: return run.x;
    default: return run.a;  // acceleration, microphone
  }
}

/// The rows [first, end) of the sensor's regression y_k = Σ_{j<4} s_j·q_{k−D−j}: its four columns.
Eigen::MatrixXd sensor_regressors(const Eigen::VectorXd& q, int delay, Eigen::Index first, Eigen::Index end) {
  Eigen::MatrixXd phi(end - first, 4);
  for (Eigen::Index k = first; k < end; ++k) {
    for (int j = 0; j < 4; ++j) {
      const Eigen::Index at = k - delay - j;
      phi(k - first, j) = at >= 0 && at < q.size() ? q[at] : 0.0;
    }
  }
  return phi;
}

/// The first row the sensor's regression uses (its past must be in the record).
Eigen::Index sensor_first_row(int delay) { return std::max<Eigen::Index>(0, delay + 3); }

/// The residual of a run: current over its norm on [first, end), then the sensor's (taps solved) over its norm.
/// Writes the sensor's taps when asked.
Eigen::VectorXd current_fit_residual(const MirrorRun& run, const CurrentFitRecord& r, Eigen::Index first,
                                     Eigen::Index end, std::array<double, 4>* taps = nullptr) {
  const Eigen::Index rows = end - first;
  const bool with_sensor = r.sensor.size() > 0;
  const Eigen::Index sensor_first = std::max(first, sensor_first_row(r.sensor_delay));
  Eigen::VectorXd res(rows + (with_sensor ? end - sensor_first : 0));
  res.head(rows) = (run.i.segment(first, rows) - r.current.segment(first, rows)) / r.current.segment(first, rows).norm();
  if (with_sensor) {
    const Eigen::MatrixXd phi = sensor_regressors(sensed_quantity(run, r.sensor_kind), r.sensor_delay, sensor_first, end);
    const Eigen::VectorXd y = r.sensor.segment(sensor_first, end - sensor_first);
    const Eigen::VectorXd s = least_squares(phi, y).theta;
    res.tail(end - sensor_first) = (phi * s - y) / y.norm();
    if (taps != nullptr) {
      for (int j = 0; j < 4; ++j) (*taps)[static_cast<std::size_t>(j)] = s[j];
    }
  }
  return res;
}

/// J of one channel, percent, on [first, end) of a run (the sensor's taps solved there).
double channel_j_pct(const Eigen::VectorXd& modelled, const Eigen::VectorXd& measured, Eigen::Index first, Eigen::Index end) {
  return 100.0 * (modelled.segment(first, end - first) - measured.segment(first, end - first)).squaredNorm() /
         measured.segment(first, end - first).squaredNorm();
}

/// The linear mechanics [M2]–[M3] with c0 = 1 driven by the measured current: v̂ and x̂ at each k.
void mechanics_from_current(const Eigen::VectorXd& current, double h, double c5, double c6, Eigen::VectorXd& x,
                            Eigen::VectorXd& v) {
  const Eigen::Index n = current.size();
  x.resize(n);
  v.resize(n);
  double xs = 0.0, vs = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    x[k] = xs;
    v[k] = vs;
    // [M2] linear, v̄ = (v_k + v_{k+1})/2 solved in closed form; [M3]
    const double v1 = (vs * (1.0 + 0.5 * h * c5) + h * (current[k] + c6 * xs)) / (1.0 - 0.5 * h * c5);
    vs = v1;
    xs += h * v1;
  }
}

/// The linear start (a): the best (f0, ζ, L, A(z), e_R, e5) with c0 = 1.
struct LinearStart {
  MirrorModel model;
  int lag = 0;
  double residual = std::numeric_limits<double>::infinity();
  double f0 = 0.0, zeta = 0.0;  // the grid point it came from
};

/// [M1] solved for the current on the rows [first, end): target i_{k+1}, regressors drive_{k−L−j} (j < taps) and
/// −v̂_{k+1}; a start when its A(z) is minimum phase and its residual the smallest so far.
void try_linear_start(const Eigen::VectorXd& drive, const Eigen::VectorXd& current, const Eigen::VectorXd& v,
                      Eigen::Index first, Eigen::Index end, int lag, double c5, double c6, double fs, LinearStart& best) {
  const Eigen::Index rows = end - first, n = drive.size();
  for (int taps = 4; taps >= 1; --taps) {
    Eigen::MatrixXd phi(rows, taps + 1);
    for (Eigen::Index k = first; k < end; ++k) {
      for (int j = 0; j < taps; ++j) {
        const Eigen::Index at = k - lag - j;
        phi(k - first, j) = at >= 0 && at < n ? drive[at] : 0.0;
      }
      phi(k - first, taps) = -v[k + 1];
    }
    const Eigen::VectorXd target = current.segment(first + 1, rows);
    const Eigen::VectorXd beta = least_squares(phi, target).theta;
    if (!(beta[0] > 0.0) || !(beta[taps] > 0.0)) continue;  // a positive resistance and back-EMF
    std::array<double, 4> a{1.0, 0.0, 0.0, 0.0};
    for (int j = 1; j < taps; ++j) a[static_cast<std::size_t>(j)] = beta[j] / beta[0];
    if (!minimum_phase(a)) continue;
    const double residual = (phi * beta - target).squaredNorm();
    if (residual < best.residual) {
      best.residual = residual;
      best.lag = lag;
      best.model = MirrorModel{};
      best.model.fs = fs;
      best.model.drive_taps = a;
      best.model.electrical[4] = 1.0 / beta[0];
      best.model.electrical[5] = beta[taps] / beta[0];
      best.model.mechanical[0] = 1.0;
      best.model.mechanical[5] = c5;
      best.model.mechanical[6] = c6;
    }
    return;  // the longest minimum-phase A(z) for this (f0, ζ, L)
  }
}

/// The linear start over a grid of resonances (10 Hz to 0.4·fs) and mechanical damping ratios, every lag, then a
/// finer grid around the best.
LinearStart linear_start(const Eigen::VectorXd& drive, const Eigen::VectorXd& current, double fs, Eigen::Index fit_end,
                         int max_delay) {
  const double h = 1.0 / fs;
  const Eigen::Index first = max_delay + 4, end = fit_end - 1;
  LinearStart best;
  Eigen::VectorXd x, v;
  const auto at = [&](double f0, double zeta, int lag_from, int lag_to) {
    const double w0 = 2.0 * std::numbers::pi * f0;
    const double c6 = -(2.0 - 2.0 * std::cos(w0 * h)) / (h * h), c5 = -2.0 * zeta * w0;  // the recursion resonates at f0
    mechanics_from_current(current, h, c5, c6, x, v);
    const double before = best.residual;
    for (int lag = lag_from; lag <= lag_to; ++lag) try_linear_start(drive, current, v, first, end, lag, c5, c6, fs, best);
    if (best.residual < before) {
      best.f0 = f0;
      best.zeta = zeta;
    }
  };
  const double top = 0.4 * fs;
  constexpr int kCoarse = 40;
  for (int g = 0; g <= kCoarse; ++g) {
    const double f0 = 10.0 * std::pow(top / 10.0, static_cast<double>(g) / kCoarse);
    for (double zeta : {0.02, 0.05, 0.1, 0.2, 0.5, 1.0}) at(f0, zeta, -2, max_delay);
  }
  if (!std::isfinite(best.residual)) return best;
  // finer: ±1 coarse step in f0, ×/÷ 1.6 in ζ, at the lag found
  const double f_best = best.f0, zeta_best = best.zeta;
  const double step = std::pow(top / 10.0, 1.0 / kCoarse);
  const int lag = best.lag;
  for (int g = -8; g <= 8; ++g) {
    for (int z = -4; z <= 4; ++z) at(f_best * std::pow(step, g / 8.0), zeta_best * std::pow(1.6, z / 4.0), lag, lag);
  }
  return best;
}

/// The sensor's delay D (−2..max): the largest whose four-tap map fits a run within 1 % of the best (a pure delay
/// inside the four taps fits at every D up to it; the largest puts it on s_0).
int best_sensor_delay(const MirrorRun& run, const CurrentFitRecord& r, int max_sensor_delay) {
  std::vector<double> residuals;
  CurrentFitRecord trial = r;
  for (int d = -2; d <= max_sensor_delay; ++d) {
    trial.sensor_delay = d;
    const Eigen::VectorXd res = current_fit_residual(run, trial, 0, r.fit_end);
    residuals.push_back(res.tail(res.size() - r.fit_end).squaredNorm());
  }
  const double smallest = *std::min_element(residuals.begin(), residuals.end());
  int best = -2;
  for (int d = -2; d <= max_sensor_delay; ++d) {
    if (residuals[static_cast<std::size_t>(d + 2)] <= 1.01 * smallest + 1e-12) best = d;
  }
  return best;
}

/// Levenberg–Marquardt on the free-run residual from θ (its size says which parameters are fitted; θ[held] stay as
/// they are); returns the steps taken and writes the loss reached.
int output_error_fit(const MirrorModel& start, const CurrentFitRecord& r, const CurrentFitScales& scales,
                     double current_peak, int max_iterations, Eigen::VectorXd& theta, double& final_loss,
                     std::initializer_list<Eigen::Index> held = {}) {
  final_loss = std::numeric_limits<double>::infinity();
  const Eigen::Index p = theta.size();
  // the linear model is time-invariant from rest, so its current is A(z) applied to the current g of the model
  // without A(z): î = g + Σ_{j≥1} a_j·g_{k−j}, and the taps are solved by least squares in each evaluation
  // (variable projection: no local minima in A(z)); θ's taps are written back, their columns of J are zero
  const bool solve_taps = p == kLinearParameters;
  MirrorRun run;
  const auto residual = [&](Eigen::VectorXd& t, Eigen::VectorXd& out) {
    MirrorModel m = current_fit_model(start, t, scales);
    if (solve_taps) m.drive_taps = {1.0, 0.0, 0.0, 0.0};
    if (!minimum_phase(m.drive_taps) || !run_current_model(m, r, current_peak, run)) return false;
    if (solve_taps) {
      const Eigen::Index rows = r.fit_end;
      Eigen::MatrixXd phi = Eigen::MatrixXd::Zero(rows, 3);
      for (int j = 1; j <= 3; ++j) phi.col(j - 1).tail(rows - j) = run.i.head(rows - j);
      const Eigen::VectorXd a = least_squares(phi, r.current.head(rows) - run.i.head(rows)).theta;
      if (!minimum_phase({1.0, a[0], a[1], a[2]})) return false;
      for (int j = 0; j < 3; ++j) t[kTap1 + j] = a[j];
      run.i.head(rows) += phi * a;
    }
    out = current_fit_residual(run, r, 0, r.fit_end);
    return out.allFinite();
  };
  Eigen::VectorXd res;
  if (!residual(theta, res)) return 0;
  double loss = res.squaredNorm();
  final_loss = loss;
  LmSettings settings;
  settings.damping = LmDamping::relative_to_largest;
  LevenbergMarquardt lm(settings, p);
  Eigen::MatrixXd jacobian(res.size(), p);
  Eigen::VectorXd plus, minus;
  int steps = 0;
  for (; steps < max_iterations; ++steps) {
    // ∂r/∂θ_j by central differences of the free run, (r(θ + δe_j) − r(θ − δe_j)) / 2δ
    for (Eigen::Index j = 0; j < p; ++j) {
      if (std::find(held.begin(), held.end(), j) != held.end()) {
        jacobian.col(j).setZero();  // no gradient: its step is exactly 0
        continue;
      }
      const double delta = 1e-6 * (1.0 + std::abs(theta[j]));
      Eigen::VectorXd t = theta;
      t[j] += delta;
      const bool up = residual(t, plus);
      t = theta;
      t[j] -= delta;
      const bool down = residual(t, minus);
      if (up && down) {
        jacobian.col(j) = (plus - minus) / (2.0 * delta);
      } else {
        jacobian.col(j).setZero();  // at the edge of the stable region: this parameter holds this step
      }
    }
    const Eigen::MatrixXd hessian = jacobian.transpose() * jacobian;
    const Eigen::VectorXd gradient = jacobian.transpose() * res;
    const LmStep step = lm.step(hessian, gradient, loss, theta, [&](const Eigen::VectorXd& candidate) {
      Eigen::VectorXd t = candidate, trial;
      return residual(t, trial) ? trial.squaredNorm() : std::numeric_limits<double>::infinity();
    });
    if (!step.accepted) break;
    const double gain = (loss - step.loss) / loss;
    loss = step.loss;
    final_loss = loss;
    residual(theta, res);
    if (gain < 1e-9) break;
  }
  return steps;
}

}  // namespace

MirrorSensorKind mirror_sensor_kind(const std::string& name) {
  if (name == "none") return MirrorSensorKind::none;
  if (name == "acceleration") return MirrorSensorKind::acceleration;
  if (name == "velocity") return MirrorSensorKind::velocity;
  if (name == "displacement") return MirrorSensorKind::displacement;
  if (name == "microphone") return MirrorSensorKind::microphone;
  throw std::invalid_argument("unknown sensor kind \"" + name +
                              "\" (known: none, acceleration, velocity, displacement, microphone)");
}

MirrorModel rescale_displacement(const MirrorModel& model, double alpha) {
  MirrorModel m = model;
  std::array<double, 11>& c = m.mechanical;
  std::array<double, 10>& e = m.electrical;
  // x = x'/α, v = v'/α: dv'/dt = α·M(x'/α, v'/α, i); E(x'/α)·v'/α
  c[0] *= alpha;
  c[2] /= alpha;
  c[3] *= alpha;
  c[7] /= alpha;
  c[8] /= alpha * alpha;
  c[9] *= alpha;
  c[10] /= alpha * alpha;
  m.friction_velocity *= alpha;
  e[1] /= alpha;
  e[2] /= alpha * alpha;
  e[5] /= alpha;
  e[6] /= alpha * alpha;
  e[7] /= alpha * alpha * alpha;
  e[8] /= alpha;
  e[9] /= alpha * alpha;
  return m;
}

MirrorCurrentFit fit_mirror_model_from_current(const Eigen::VectorXd& drive, const Eigen::VectorXd& current, double fs,
                                               const MirrorCurrentFitOptions& o, const Eigen::VectorXd& sensor) {
  const Eigen::Index n = drive.size();
  if (current.size() != n || (sensor.size() != 0 && sensor.size() != n)) {
    throw std::invalid_argument("mirror current fit: drive, current and sensor must have the same length (" +
                                std::to_string(n) + ", " + std::to_string(current.size()) + ", " +
                                std::to_string(sensor.size()) + ")");
  }
  if (n < 1000) throw std::invalid_argument("mirror current fit: at least 1000 samples are needed, got " + std::to_string(n));
  if (!(fs > 0.0)) throw std::invalid_argument("mirror current fit: fs must be > 0");
  if (o.max_delay < 0 || o.max_delay > 64) throw std::invalid_argument("mirror current fit: max_delay must be within [0, 64]");
  if (o.max_sensor_delay < 0 || o.max_sensor_delay > 256) {
    throw std::invalid_argument("mirror current fit: max_sensor_delay must be within [0, 256]");
  }
  if (!(o.validation_share >= 0.1 && o.validation_share <= 0.5)) {
    throw std::invalid_argument("mirror current fit: validation_share must be within [0.1, 0.5]");
  }
  if (sensor.size() != 0 && o.sensor_kind == MirrorSensorKind::none) {
    throw std::invalid_argument("mirror current fit: a sensor column needs its kind (acceleration, velocity, displacement or microphone)");
  }
  for (Eigen::Index k = 0; k < n; ++k) {
    if (!std::isfinite(drive[k]) || !std::isfinite(current[k]) || (sensor.size() != 0 && !std::isfinite(sensor[k]))) {
      throw std::invalid_argument("mirror current fit: sample " + std::to_string(k) + " is not finite");
    }
  }
  const double current_peak = current.cwiseAbs().maxCoeff();
  if (!(current_peak > 0.0)) throw std::invalid_argument("mirror current fit: the current is zero throughout");
  const double current_rms = std::sqrt(current.squaredNorm() / static_cast<double>(n));

  const Eigen::Index fit_end = n - static_cast<Eigen::Index>(std::round(o.validation_share * static_cast<double>(n)));
  // (a) the linear start from the current alone
  LinearStart start = linear_start(drive, current, fs, fit_end, o.max_delay);
  if (!std::isfinite(start.residual)) {
    throw std::invalid_argument("mirror current fit: no linear model with a minimum-phase drive path fits the current");
  }
  const Eigen::VectorXd no_sensor;
  const CurrentFitRecord current_record{drive, current, no_sensor, MirrorSensorKind::none, fit_end, start.lag, 0};
  CurrentFitRecord record{drive, current, sensor, sensor.size() != 0 ? o.sensor_kind : MirrorSensorKind::none, fit_end,
                          start.lag, 0};
  // the scale of x: rms 1 over the fitting part, in the linear model's free run
  MirrorRun run;
  if (!run_current_model(start.model, current_record, current_peak, run)) {
    throw std::invalid_argument("mirror current fit: the linear start runs away in free run");
  }
  const double x_rms = std::sqrt(run.x.head(fit_end).squaredNorm() / static_cast<double>(fit_end));
  MirrorModel linear = rescale_displacement(start.model, 1.0 / x_rms);
  const double v_rms = std::sqrt(run.v.head(fit_end).squaredNorm() / static_cast<double>(fit_end)) / x_rms;
  linear.friction_velocity = 0.2 * v_rms;  // the friction's switch a fifth of the way to the typical velocity
  const CurrentFitScales scales{current_rms, v_rms};

  MirrorCurrentFit fit;
  // (b) output error: the linear parameters on the current alone, then every parameter (with the sensor)
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(kLinearParameters);
  double linear_loss = 0.0;
  fit.iterations = output_error_fit(linear, current_record, scales, current_peak, o.max_iterations, theta, linear_loss);
  const MirrorModel linear_fitted = current_fit_model(linear, theta, scales);
  run_current_model(linear_fitted, current_record, current_peak, run);
  fit.linear_j_val_pct = channel_j_pct(run.i, current, fit_end, n);
  if (sensor.size() != 0) {
    const int max_sensor_delay = o.sensor_kind == MirrorSensorKind::microphone ? std::max(o.max_sensor_delay, 64) : o.max_sensor_delay;
    record.sensor_delay = best_sensor_delay(run, record, max_sensor_delay);
  }
  Eigen::VectorXd full = Eigen::VectorXd::Zero(kCurrentFitParameters);
  full.head(kLinearParameters) = theta;
  double loss = 0.0;
  fit.iterations +=
      output_error_fit(linear, record, scales, current_peak, o.max_iterations, full, loss, {kDampingRise, kForceFactor1});
  fit.model = current_fit_model(linear, full, scales);
  // (c) free run over the whole record; J per channel on the fitting part and on validation
  run_current_model(fit.model, record, current_peak, run);
  fit.current_j_val_pct = channel_j_pct(run.i, current, fit_end, n);
  // Rms(v)'s rise, then Bl(x)'s asymmetry from there, each kept when it cuts the current's J_val on validation: Rms(v)
  // by 0.5 % and only when not negligible itself (more iterations alone cut the J_val of a record the model holds
  // exactly; at the multisine's velocities Rms(v) adds a few percent to the resistance and the current shows little of
  // it: on panel-exciter-rms-v J_val 0.00926 → 0.00914 %, r2·v_rms² 0.030, and the 160 Hz cut at 0.2 rose 8.5 → 14.5
  // dB; on panel-exciter it fits at 0.0007, below the floor), b1 by 10 % (it trades with K(x)'s asymmetry) at any size
  // (second-exciter's b1 = 0.05/mm fits at b1·x_rms = 0.008, and without it its 80 Hz cut is 8 dB instead of 19)
  const auto earns_its_place = [&](Eigen::VectorXd& theta_with, Eigen::Index parameter, double smallest,
                                   double least_cut, std::initializer_list<Eigen::Index> held) {
    Eigen::VectorXd trial_theta = theta_with;
    fit.iterations += output_error_fit(linear, record, scales, current_peak, o.max_iterations, trial_theta, loss, held);
    if (!(std::abs(trial_theta[parameter]) >= smallest)) return false;
    const MirrorModel with = current_fit_model(linear, trial_theta, scales);
    MirrorRun trial;
    if (!run_current_model(with, record, current_peak, trial)) return false;
    const double j_val = channel_j_pct(trial.i, current, fit_end, n);
    if (!(j_val < (1.0 - least_cut) * fit.current_j_val_pct)) return false;
    fit.model = with;
    fit.current_j_val_pct = j_val;
    run = trial;
    theta_with = trial_theta;
    return true;
  };
  constexpr double kSmallestDampingRise = 0.01;  // r2·v_rms²: the resistance 1 % up at the rms velocity
  fit.damping_rise = earns_its_place(full, kDampingRise, kSmallestDampingRise, 0.005, {kForceFactor1});
  fit.force_factor_asymmetry =
      earns_its_place(full, kForceFactor1, 0.0, 0.1,
                      fit.damping_rise ? std::initializer_list<Eigen::Index>{} : std::initializer_list<Eigen::Index>{kDampingRise});
  fit.current_lag = start.lag;
  fit.model.delay = std::max(start.lag, 0);
  fit.current_j_fit_pct = channel_j_pct(run.i, current, 0, fit_end);
  fit.current_j_val_pct = channel_j_pct(run.i, current, fit_end, n);
  if (sensor.size() != 0) {
    // the sensor's taps from the fitting part, judged on validation
    const Eigen::Index first = sensor_first_row(record.sensor_delay);
    (void)current_fit_residual(run, record, first, fit_end, &fit.sensor_taps);
    const Eigen::MatrixXd phi = sensor_regressors(sensed_quantity(run, record.sensor_kind), record.sensor_delay, fit_end, n);
    const Eigen::Map<const Eigen::Vector4d> taps(fit.sensor_taps.data());
    fit.sensor_j_val_pct = channel_j_pct(phi * taps, sensor.segment(fit_end, n - fit_end), 0, n - fit_end);
    fit.sensor_delay = record.sensor_delay;
  }
  const double h = 1.0 / fs;
  fit.resonance_hz = std::acos(std::clamp(1.0 + 0.5 * h * h * fit.model.mechanical[6], -1.0, 1.0)) / (2.0 * std::numbers::pi * h);
  return fit;
}

MirrorModel add_eddy_branch(const MirrorModel& model, const MirrorEddyBranch& branch) {
  MirrorModel m = model;
  m.eddy = branch;
  const EddyStep step = eddy_step(branch);
  // the branch's voltage g·(1 − z⁻¹)/(1 − p·z⁻¹)·i over e_R: g/e_R·(1 − (1 − p)·Σ_{k≥1} p^{k−1}·z⁻ᵏ)
  const double share = step.resistance / model.electrical[4];
  std::array<double, 4> series{1.0 + share, 0.0, 0.0, 0.0};
  for (std::size_t k = 1; k < 4; ++k) series[k] = -share * (1.0 - step.pole) * std::pow(step.pole, static_cast<double>(k - 1));
  // A'(z) = A(z)·(1 + G_b(z)/e_R) to four taps, and [M1] over its first tap (so that a'_0 = 1)
  std::array<double, 4> taps{};
  for (std::size_t j = 0; j < 4; ++j) {
    for (std::size_t k = 0; k + j < 4; ++k) taps[j + k] += model.drive_taps[j] * series[k];
  }
  const double scale = 1.0 / taps[0];
  for (double& a : taps) a *= scale;
  m.drive_taps = taps;
  for (double& e : m.electrical) e *= scale;
  m.eddy.resistance *= scale;
  return m;
}

MirrorCurrentFit refit_mirror_model_from_current(const Eigen::VectorXd& drive, const Eigen::VectorXd& current, double fs,
                                                 const MirrorModel& from, int lag, const MirrorCurrentFitOptions& o) {
  const Eigen::Index n = drive.size();
  if (current.size() != n || n < 1000 || !(fs > 0.0) || !drive.allFinite() || !current.allFinite()) {
    throw std::invalid_argument("mirror current refit: drive and current must be finite, of equal length and ≥ 1000 samples");
  }
  if (!(o.validation_share >= 0.1 && o.validation_share <= 0.5)) {
    throw std::invalid_argument("mirror current refit: validation_share must be within [0.1, 0.5]");
  }
  if (!(from.mechanical[0] != 0.0 && from.mechanical[6] != 0.0 && from.electrical[4] != 0.0)) {
    throw std::invalid_argument("mirror current refit: the model has no force factor, stiffness or resistance to start from");
  }
  const double current_peak = current.cwiseAbs().maxCoeff();
  if (!(current_peak > 0.0)) throw std::invalid_argument("mirror current refit: the current is zero throughout");
  const Eigen::Index fit_end = n - static_cast<Eigen::Index>(std::round(o.validation_share * static_cast<double>(n)));
  const Eigen::VectorXd no_sensor;
  const CurrentFitRecord record{drive, current, no_sensor, MirrorSensorKind::none, fit_end, lag, 0};
  MirrorRun run;
  if (!run_current_model(from, record, current_peak, run)) {
    throw std::invalid_argument("mirror current refit: the model to start from runs away on the record");
  }
  const CurrentFitScales scales{std::sqrt(current.squaredNorm() / static_cast<double>(n)),
                                std::sqrt(run.v.head(fit_end).squaredNorm() / static_cast<double>(fit_end))};
  Eigen::VectorXd theta = theta_of(from, scales);
  double loss = 0.0;
  MirrorCurrentFit fit;
  fit.damping_rise = from.mechanical[10] != 0.0;
  fit.force_factor_asymmetry = from.mechanical[1] != 0.0;
  // Rms(v)'s rise and Bl(x)'s asymmetry stay out where the fit left them out
  if (fit.damping_rise && fit.force_factor_asymmetry) {
    fit.iterations = output_error_fit(from, record, scales, current_peak, o.max_iterations, theta, loss);
  } else if (fit.damping_rise) {
    fit.iterations = output_error_fit(from, record, scales, current_peak, o.max_iterations, theta, loss, {kForceFactor1});
  } else if (fit.force_factor_asymmetry) {
    fit.iterations = output_error_fit(from, record, scales, current_peak, o.max_iterations, theta, loss, {kDampingRise});
  } else {
    fit.iterations =
        output_error_fit(from, record, scales, current_peak, o.max_iterations, theta, loss, {kDampingRise, kForceFactor1});
  }
  fit.model = current_fit_model(from, theta, scales);
  fit.model.observer = from.observer;
  fit.model.delay = std::max(lag, 0);
  fit.current_lag = lag;
  if (!run_current_model(fit.model, record, current_peak, run)) {
    throw std::invalid_argument("mirror current refit: the refitted model runs away on the record");
  }
  fit.current_j_fit_pct = channel_j_pct(run.i, current, 0, fit_end);
  fit.current_j_val_pct = channel_j_pct(run.i, current, fit_end, n);
  const double h = 1.0 / fs;
  fit.resonance_hz = std::acos(std::clamp(1.0 + 0.5 * h * h * fit.model.mechanical[6], -1.0, 1.0)) / (2.0 * std::numbers::pi * h);
  return fit;
}

}  // namespace panelbass::models

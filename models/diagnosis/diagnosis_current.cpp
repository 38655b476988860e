#include "models/diagnosis/diagnosis_current.h"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>

#include "models/optimization/least_squares.h"
#include "models/validation/performance.h"

namespace panelbass::models::diagnosis_detail {
namespace {

// Samples by which a force feature may lead or lag the force channel's path: the states come from the
// sensed output, which the anti-alias filter delays by a sample or two against the motion itself; no more, so
// that a phase cannot turn x³ into v³.
constexpr int kForceLead = 2;
constexpr int kForceLag = 1;

// x − mean, over its rms measured on `reference` (the estimation record's): unit rms there.
Eigen::VectorXd normalised_like(const Eigen::VectorXd& x, const Eigen::VectorXd& reference) {
  const double mean = reference.mean();
  const double rms = std::sqrt((reference.array() - mean).square().mean());
  return (x.array() - mean) / (rms > 0.0 ? rms : 1.0);
}

// The motion a force feature is a function of, and the current, each of unit rms on the estimation record.
struct Motion {
  Eigen::VectorXd x, v, i;
};

// v(k) = z(k) − z(k−1), v(0) = 0, over its rms.
Eigen::VectorXd unit_rate(const Eigen::VectorXd& z) {
  Eigen::VectorXd v = Eigen::VectorXd::Zero(z.size());
  for (Eigen::Index k = 1; k < z.size(); ++k) v[k] = z[k] - z[k - 1];
  const double rms = std::sqrt(v.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, v.size())));
  return v / (rms > 0.0 ? rms : 1.0);
}

Motion motion_of(const StateSignals& s, OutputQuantity q, const Eigen::VectorXd& i, const Eigen::VectorXd& i_reference) {
  Motion m;
  switch (q) {
    case OutputQuantity::displacement: m.x = s.output, m.v = unit_rate(s.output); break;
    case OutputQuantity::velocity: m.x = s.integral, m.v = s.output; break;
    default: m.x = s.double_integral, m.v = s.integral; break;  // an accelerometer (the virtual transducer's)
  }
  m.i = normalised_like(i, i_reference);
  return m;
}

// The force features of `effect` (no columns when it is not a force of the motion), each without the part
// the linear signals x, v, i and a constant explain.
Eigen::MatrixXd force_features(Effect effect, const Motion& m) {
  const Eigen::Index n = m.x.size();
  Eigen::MatrixXd g(n, 0);
  auto one = [&](const Eigen::ArrayXd& f) {
    g.resize(n, 1);
    g.col(0) = f.matrix();
  };
  const Eigen::ArrayXd x = m.x.array(), v = m.v.array(), i = m.i.array();
  switch (effect) {
    case Effect::cubic_stiffness: one(x.cube()); break;          // K(x)·x beyond K₀x: x³
    case Effect::asymmetric_stiffness: one(x.square()); break;   // x²
    case Effect::nonlinear_damping: one(v.cube()); break;        // Rms(v)·v beyond Rm·v: v³
    case Effect::hysteresis: one((v / 0.1).tanh()); break;       // friction: the direction of motion
    case Effect::force_factor: one(x.square() * i); break;       // Bl(x)·i beyond Bl₀·i: x²·i
    case Effect::asymmetric_force_factor: one(x * i); break;     // a coil offset: x·i
    case Effect::inductance: one(i.square()); break;             // the reluctance force ½·i²·dLe/dx
    default: return g;
  }
  Eigen::MatrixXd linear(n, 4);
  linear << m.x, m.v, m.i, Eigen::VectorXd::Ones(n);
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(linear);
  for (Eigen::Index j = 0; j < g.cols(); ++j) g.col(j) -= linear * qr.solve(g.col(j));
  return g;
}

// The features through the path (scaled units), each shifted by −kForceLead..kForceLag samples.
Eigen::MatrixXd force_regressors(const Eigen::MatrixXd& g, const TransferFunction& path) {
  const int width = kForceLead + kForceLag + 1;
  Eigen::MatrixXd phi = Eigen::MatrixXd::Zero(g.rows(), width * g.cols());
  for (Eigen::Index j = 0; j < g.cols(); ++j) {
    const Eigen::VectorXd f = filter_through(path, g.col(j));
    for (int l = -kForceLead; l <= kForceLag; ++l) {
      const Eigen::Index c = j * width + l + kForceLead, m = f.size() - std::abs(l);
      if (l >= 0) phi.col(c).tail(m) = f.head(m);
      else phi.col(c).head(m) = f.tail(m);
    }
  }
  return phi;
}

// The regressors of every effect of `effects` on one record, side by side.
Eigen::MatrixXd stacked_force_regressors(const std::vector<Effect>& effects, const Motion& m, const TransferFunction& path) {
  std::vector<Eigen::MatrixXd> blocks;
  Eigen::Index cols = 0;
  for (Effect e : effects) {
    blocks.push_back(force_regressors(force_features(e, m), path));
    cols += blocks.back().cols();
  }
  Eigen::MatrixXd phi(m.x.size(), cols);
  Eigen::Index at = 0;
  for (const auto& b : blocks) phi.middleCols(at, b.cols()) = b, at += b.cols();
  return phi;
}

}  // namespace

ForceChannel force_channel(const Records& r, const LinearModel& path, const Eigen::VectorXd& i_est,
                           const Eigen::VectorXd& i_val) {
  ForceChannel c;
  c.path = path;
  c.i_est = &i_est;
  c.i_val = &i_val;
  c.residual_est = path.scaling.scale_y(r.y_est) - path.scaling.scale_y(path.simulate(i_est, r.y_est, r.init));
  c.residual_val = path.scaling.scale_y(r.y_val) - path.scaling.scale_y(path.simulate(i_val, r.y_val, r.init));
  const Eigen::Index n = r.y_val.size() - r.init;
  const Eigen::VectorXd y = path.scaling.scale_y(r.y_val).tail(n);
  c.y_energy_val = y.squaredNorm();
  c.j_val_pct = j_ratio_percent(c.residual_val.tail(n).squaredNorm(), c.y_energy_val, "the force channel's output");
  return c;
}

bool acts_as_force(Effect effect) {
  switch (effect) {
    case Effect::cubic_stiffness:
    case Effect::asymmetric_stiffness:
    case Effect::nonlinear_damping:
    case Effect::hysteresis:
    case Effect::force_factor:
    case Effect::asymmetric_force_factor:
    case Effect::inductance:
      return true;
    default:
      return false;
  }
}

bool look_alike(Effect a, Effect b) {
  auto pair = [&](Effect p, Effect q) { return (a == p && b == q) || (a == q && b == p); };
  return pair(Effect::nonlinear_damping, Effect::cubic_stiffness) || pair(Effect::nonlinear_damping, Effect::hysteresis) ||
         pair(Effect::nonlinear_damping, Effect::force_factor) ||
         pair(Effect::asymmetric_force_factor, Effect::asymmetric_stiffness) ||
         pair(Effect::asymmetric_force_factor, Effect::inductance) || pair(Effect::creep, Effect::resonance) ||
         pair(Effect::creep, Effect::antiresonance);
}

ForceScore force_score(const ForceChannel& channel, const Records& r, const Fit& current, Effect effect,
                       const std::vector<Effect>& kept) {
  ForceScore out;
  std::vector<Effect> base;
  for (Effect e : kept)
    if (acts_as_force(e)) base.push_back(e);
  const bool already = std::find(base.begin(), base.end(), effect) != base.end();
  // The states of the motion the current explains: the force channel's path simulated from the measured current
  // (from rest). Not the drive's model (`current`): on a visible spring its linear resonance lies where the spring
  // at rest puts it, and the phase error near resonance made v³ fit the spring's force better than x³.
  const LinearModel& linear = current.model.linear;
  const Eigen::VectorXd ys_est = linear.scaling.scale_y(channel.path.simulate(*channel.i_est, r.y_est, 0));
  const Eigen::VectorXd ys_val = linear.scaling.scale_y(channel.path.simulate(*channel.i_val, r.y_val, 0));
  const StateSignals s_est = state_signals(linear.scaling.scale_u(r.u_est), ys_est, r.fs);
  const StateSignals s_val = state_signals(linear.scaling.scale_u(r.u_val), ys_val, r.fs, &s_est);
  const Motion m_est = motion_of(s_est, r.output, *channel.i_est, *channel.i_est);
  const Motion m_val = motion_of(s_val, r.output, *channel.i_val, *channel.i_est);
  const Eigen::Index n_est = r.y_est.size() - r.init, n_val = r.y_val.size() - r.init;
  // [2A] J of the channel's residual with the features of `effects` fitted on the estimation record.
  auto j_with = [&](const std::vector<Effect>& effects) {
    const std::string channel_name = "the force channel's output";
    if (effects.empty()) return j_ratio_percent(channel.residual_val.tail(n_val).squaredNorm(), channel.y_energy_val, channel_name);
    const Eigen::MatrixXd phi_est = stacked_force_regressors(effects, m_est, channel.path.tf).bottomRows(n_est);
    const Eigen::MatrixXd phi_val = stacked_force_regressors(effects, m_val, channel.path.tf).bottomRows(n_val);
    const Eigen::VectorXd c = least_squares(phi_est, channel.residual_est.tail(n_est)).theta;
    return j_ratio_percent((channel.residual_val.tail(n_val) - phi_val * c).squaredNorm(), channel.y_energy_val, channel_name);
  };
  out.j_before_pct = j_with(base);
  if (already || !acts_as_force(effect)) {
    out.j_after_pct = out.j_before_pct;
    return out;
  }
  std::vector<Effect> with = base;
  with.push_back(effect);
  out.j_after_pct = j_with(with);
  out.parameters = kForceLead + kForceLag + 1;
  const double n = static_cast<double>(n_val);
  out.score = n * std::log(out.j_before_pct / out.j_after_pct) - out.parameters * std::log(n);
  return out;
}

}  // namespace panelbass::models::diagnosis_detail

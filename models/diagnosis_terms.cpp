#include "models/diagnosis_terms.h"

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace panelbass::models {
namespace {

// (x − mean)/rms, with the mean and rms measured here (slot not yet set) or taken from the reference.
Eigen::VectorXd normalised(Eigen::VectorXd x, int slot, StateSignals& s, const StateSignals* reference) {
  if (reference != nullptr) {
    s.mean[slot] = reference->mean[slot];
    s.rms[slot] = reference->rms[slot];
  } else {
    s.mean[slot] = x.mean();
    const Eigen::VectorXd c = x.array() - s.mean[slot];
    const double r = std::sqrt(c.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, x.size())));
    s.rms[slot] = r > 0.0 ? r : 1.0;
  }
  return (x.array() - s.mean[slot]) / s.rms[slot];
}

// x_int(k) = λ·x_int(k−1) + x(k)/fs, λ = exp(−2π·f_c/fs): an integrator above f_c.
Eigen::VectorXd leaky_integral(const Eigen::VectorXd& x, double fs) {
  const double lambda = std::exp(-2.0 * std::numbers::pi / 500.0);
  Eigen::VectorXd out(x.size());
  double s = 0.0;
  for (Eigen::Index k = 0; k < x.size(); ++k) out[k] = s = lambda * s + x[k] / fs;
  return out;
}

// x minus its projection on `basis` (what a linear model of `basis` already explains).
Eigen::VectorXd orthogonal_to(Eigen::VectorXd x, const Eigen::VectorXd& basis) {
  const double d = basis.squaredNorm();
  if (d > 0.0) x -= (basis.dot(x) / d) * basis;
  return x;
}

}  // namespace

std::string to_string(Effect effect) {
  switch (effect) {
    case Effect::resonance: return "resonance";
    case Effect::antiresonance: return "antiresonance";
    case Effect::delay: return "delay";
    case Effect::cubic_stiffness: return "cubic_stiffness";
    case Effect::asymmetric_stiffness: return "asymmetric_stiffness";
    case Effect::force_factor: return "force_factor";
    case Effect::inductance: return "inductance";
    case Effect::hysteresis: return "hysteresis";
    case Effect::saturation: return "saturation";
    case Effect::thermal_compression: return "thermal_compression";
    case Effect::dc_offset: return "dc_offset";
  }
  return "unknown";
}

std::string to_string(StateProxy proxy) {
  switch (proxy) {
    case StateProxy::output: return "output";
    case StateProxy::integral: return "integral";
    case StateProxy::double_integral: return "double_integral";
    case StateProxy::input: return "input";
  }
  return "unknown";
}

const Eigen::VectorXd& StateSignals::of(StateProxy proxy) const {
  switch (proxy) {
    case StateProxy::output: return output;
    case StateProxy::integral: return integral;
    case StateProxy::double_integral: return double_integral;
    case StateProxy::input: return input;
  }
  throw std::invalid_argument("StateSignals::of: unknown proxy");
}

StateSignals state_signals(const Eigen::VectorXd& u, const Eigen::VectorXd& y_sim, double fs,
                           const StateSignals* reference) {
  StateSignals s;
  s.input = normalised(u, 3, s, reference);
  s.output = normalised(y_sim, 0, s, reference);
  s.integral = normalised(leaky_integral(s.output, fs), 1, s, reference);
  s.double_integral = normalised(leaky_integral(s.integral, fs), 2, s, reference);
  return s;
}

Eigen::VectorXd filter_through(const TransferFunction& tf, const Eigen::VectorXd& x) {
  // y(k) = Σ_j b_j·x(k−nk−j) − Σ_i a_i·y(k−i)
  const Eigen::Index n = x.size();
  Eigen::VectorXd y = Eigen::VectorXd::Zero(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    double acc = 0.0;
    for (Eigen::Index j = 0; j < tf.b.size(); ++j) {
      const Eigen::Index t = k - tf.nk - j;
      if (t >= 0) acc += tf.b[j] * x[t];
    }
    for (Eigen::Index i = 0; i < tf.a.size(); ++i)
      if (k - 1 - i >= 0) acc -= tf.a[i] * y[k - 1 - i];
    y[k] = acc;
  }
  return y;
}

Eigen::VectorXd term_feature(const DiagnosisTerm& term, const StateSignals& states) {
  const Eigen::VectorXd& z = states.of(term.proxy);
  switch (term.effect) {
    case Effect::cubic_stiffness:  // a restoring force K·k2·x³ beyond the linear spring
      return orthogonal_to(z.array().cube().matrix(), z);
    case Effect::asymmetric_stiffness: {  // K·k1·x²: even, with a DC part
      Eigen::VectorXd g = z.array().square().matrix();
      g.array() -= g.mean();
      return orthogonal_to(g, z);
    }
    case Effect::hysteresis: {  // friction Fc·tanh(v/v0): the direction of motion, v = dz/dt
      Eigen::VectorXd v = Eigen::VectorXd::Zero(z.size());
      for (Eigen::Index k = 1; k < z.size(); ++k) v[k] = z[k] - z[k - 1];
      const double r = std::sqrt(v.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, v.size())));
      Eigen::VectorXd g = (v.array() / (0.1 * std::max(r, 1e-300))).tanh().matrix();
      return orthogonal_to(orthogonal_to(g, v), z);
    }
    case Effect::saturation: {  // the drive beyond a knee: (|u| − c)₊·sign(u)
      const double c = term.threshold;
      Eigen::VectorXd g(z.size());
      for (Eigen::Index k = 0; k < z.size(); ++k) g[k] = std::max(std::abs(z[k]) - c, 0.0) * (z[k] < 0 ? -1.0 : 1.0);
      return orthogonal_to(g, z);
    }
    case Effect::dc_offset: return Eigen::VectorXd::Ones(z.size());
    default: throw std::invalid_argument("term_feature: no static term for effect " + to_string(term.effect));
  }
}

Eigen::MatrixXd term_regressors(const DiagnosisTerm& term, const StateSignals& states,
                                const TransferFunction& dynamics, int lags) {
  const Eigen::VectorXd g = term_feature(term, states);
  if (term.effect == Effect::dc_offset) return g;
  const Eigen::VectorXd f = filter_through(dynamics, g);
  Eigen::MatrixXd phi = Eigen::MatrixXd::Zero(f.size(), lags + kTermLead);
  for (int l = -kTermLead; l < lags; ++l) {
    const Eigen::Index c = l + kTermLead, m = f.size() - std::abs(l);
    if (l >= 0) phi.col(c).tail(m) = f.head(m);
    else phi.col(c).head(m) = f.tail(m);
  }
  return phi;
}

}  // namespace panelbass::models

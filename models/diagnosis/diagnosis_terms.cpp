#include "models/diagnosis/diagnosis_terms.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "dsp/leaky_integral.h"

namespace panelbass::models {
namespace {

// (x − mean)/rms, with the mean and rms measured here (no reference) or taken from the reference. With
// `own_mean` the mean is always this record's: an integral's slow wander differs from record to record.
Eigen::VectorXd normalised(Eigen::VectorXd x, int slot, StateSignals& s, const StateSignals* reference,
                           bool own_mean = false) {
  const double mean = x.mean();
  if (reference != nullptr) {
    s.mean[slot] = own_mean ? mean : reference->mean[slot];
    s.rms[slot] = reference->rms[slot];
  } else {
    s.mean[slot] = mean;
    const Eigen::VectorXd c = x.array() - mean;
    const double r = std::sqrt(c.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, x.size())));
    s.rms[slot] = r > 0.0 ? r : 1.0;
  }
  return (x.array() - s.mean[slot]) / s.rms[slot];
}

// T(k) = λ·T(k−1) + (1 − λ)·u(k)², λ = exp(−1/τ) (τ in samples): a first-order thermal state driven by
// the power. It starts at the mean power of its first τ samples (the record starts warm, not cold).
Eigen::VectorXd slow_power(const Eigen::VectorXd& u, double tau_samples) {
  if (!(tau_samples > 0.0)) throw std::invalid_argument("slow_power: the time constant must be positive");
  const double lambda = std::exp(-1.0 / tau_samples);
  const Eigen::Index warm = std::min<Eigen::Index>(u.size(), static_cast<Eigen::Index>(std::ceil(tau_samples)));
  double t = warm > 0 ? u.head(warm).squaredNorm() / static_cast<double>(warm) : 0.0;
  Eigen::VectorXd out(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) out[k] = t = lambda * t + (1.0 - lambda) * u[k] * u[k];
  return out;
}

// v(k) = x(k) − x(k−1), v(0) = 0.
Eigen::VectorXd first_difference(const Eigen::VectorXd& x) {
  Eigen::VectorXd v = Eigen::VectorXd::Zero(x.size());
  for (Eigen::Index k = 1; k < x.size(); ++k) v[k] = x[k] - x[k - 1];
  return v;
}

// x minus its projection on `basis` (what a linear model of `basis` already explains).
Eigen::VectorXd orthogonal_to(Eigen::VectorXd x, const Eigen::VectorXd& basis) {
  const double d = basis.squaredNorm();
  if (d > 0.0) x -= (basis.dot(x) / d) * basis;
  return x;
}

// x without its mean (a feature with a DC part, which the offset term owns), then orthogonal to `basis`.
Eigen::VectorXd centred_orthogonal_to(Eigen::VectorXd x, const Eigen::VectorXd& basis) {
  x.array() -= x.mean();
  return orthogonal_to(std::move(x), basis);
}

// The drive beyond a knee c: on both sides alike, (|z| − c)₊·sign(z), one column orthogonal to z; or each side
// on its own, (z − c)₊ and (z + c)₋, two columns (one alone bends one way: a diode).
Eigen::MatrixXd knee_features(const Eigen::VectorXd& z, double c, bool one_sided) {
  if (!one_sided) {
    Eigen::VectorXd g(z.size());
    for (Eigen::Index k = 0; k < z.size(); ++k) g[k] = std::max(std::abs(z[k]) - c, 0.0) * (z[k] < 0 ? -1.0 : 1.0);
    return orthogonal_to(g, z);
  }
  Eigen::MatrixXd g(z.size(), 2);
  for (Eigen::Index k = 0; k < z.size(); ++k) {
    g(k, 0) = std::max(z[k] - c, 0.0);
    g(k, 1) = std::min(z[k] + c, 0.0);
  }
  for (Eigen::Index j = 0; j < 2; ++j) g.col(j) = centred_orthogonal_to(g.col(j), z);
  return g;
}

}  // namespace

bool has_block_filters(const DiagnosisTerm& term) {
  return term.effect == Effect::static_nonlinearity || (term.effect == Effect::saturation && term.front.b.size() > 0);
}

bool reads_only_the_input(const DiagnosisTerm& term) {
  return term.effect == Effect::dc_offset || term.effect == Effect::thermal_compression || has_block_filters(term) ||
         term.proxy == StateProxy::input;
}

Eigen::VectorXd static_nonlinearity_signal(const DiagnosisTerm& term, const StateSignals& states) {
  if (!has_block_filters(term)) return states.of(term.proxy);
  return filter_through(term.front, states.input) / term.front_rms;
}

std::string to_string(Position position) {
  switch (position) {
    case Position::input: return "input";
    case Position::output: return "output";
    case Position::between: return "between";
  }
  return "unknown";
}

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
    case Effect::static_nonlinearity: return "static_nonlinearity";
    case Effect::nonlinear_damping: return "nonlinear_damping";
    case Effect::asymmetric_force_factor: return "asymmetric_force_factor";
    case Effect::creep: return "creep";
  }
  return "unknown";
}

std::vector<Effect> all_effects() {
  return {Effect::resonance,  Effect::antiresonance, Effect::delay,      Effect::cubic_stiffness,
          Effect::asymmetric_stiffness, Effect::force_factor, Effect::inductance, Effect::hysteresis,
          Effect::saturation, Effect::thermal_compression, Effect::dc_offset, Effect::static_nonlinearity,
          Effect::nonlinear_damping, Effect::asymmetric_force_factor, Effect::creep};
}

std::string vocabulary_text() {
  std::string text;
  for (Effect e : all_effects()) text += (text.empty() ? "" : ", ") + to_string(e);
  return text;
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
  s.fs = fs;
  s.input = normalised(u, 3, s, reference);
  s.output = normalised(y_sim, 0, s, reference);
  // The integrals of the output without its own mean: a DC part, integrated, would grow without bound.
  const Eigen::VectorXd centred = s.output.array() - s.output.mean();
  s.integral = normalised(dsp::leaky_integral(centred, fs), 1, s, reference, true);
  s.double_integral = normalised(dsp::leaky_integral(s.integral, fs), 2, s, reference, true);
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
    case Effect::asymmetric_stiffness:  // K·k1·x²: even, with a DC part
      return centred_orthogonal_to(z.array().square().matrix(), z);
    case Effect::hysteresis: {  // friction Fc·tanh(v/v0): the direction of motion, v = dz/dt
      const Eigen::VectorXd v = first_difference(z);
      const double r = std::sqrt(v.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, v.size())));
      Eigen::VectorXd g = (v.array() / (0.1 * std::max(r, 1e-300))).tanh().matrix();
      return orthogonal_to(orthogonal_to(g, v), z);
    }
    case Effect::nonlinear_damping: {  // Rms(v)·v = Rm·v + Rm·r2·v³: the cube of the velocity, v = dz/dt
      const Eigen::VectorXd v = first_difference(z);
      const double r = std::sqrt(v.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, v.size())));
      const Eigen::VectorXd w = v / std::max(r, 1e-300);
      return orthogonal_to(orthogonal_to(w.array().cube().matrix(), w), z);
    }
    case Effect::saturation:  // the drive beyond a knee: the first of term_features'
    case Effect::force_factor:
    case Effect::asymmetric_force_factor:
    case Effect::inductance:
    case Effect::static_nonlinearity:
      return term_features(term, states).col(0);
    case Effect::thermal_compression: {  // Re(T): the current falls by ∝ u·ΔT, T a low-pass of the power u²
      const Eigen::VectorXd& u = states.input;
      const Eigen::VectorXd p = slow_power(u, term.time_constant_s * states.fs);
      Eigen::VectorXd g = (u.array() * (p.array() - p.mean())).matrix();
      return orthogonal_to(g, u);
    }
    case Effect::creep: {  // F = K0·(x − c·z), τ·dz/dt = x − z: the relaxed displacement z, beyond x itself
      const double lambda = std::exp(-1.0 / (term.time_constant_s * states.fs));
      Eigen::VectorXd relaxed(z.size());
      double state = 0.0;
      for (Eigen::Index k = 0; k < z.size(); ++k) relaxed[k] = state = lambda * state + (1.0 - lambda) * z[k];
      return orthogonal_to(relaxed, z);
    }
    case Effect::dc_offset: return Eigen::VectorXd::Ones(z.size());
    default: throw std::invalid_argument("term_feature: no static term for effect " + to_string(term.effect));
  }
}

int feature_count(const DiagnosisTerm& term) {
  if (term.effect == Effect::static_nonlinearity && term.shape == Shape::polynomial) return 2;
  if (term.effect == Effect::saturation || term.effect == Effect::static_nonlinearity) return term.one_sided ? 2 : 1;
  return term.effect == Effect::force_factor || term.effect == Effect::asymmetric_force_factor ||
                 term.effect == Effect::inductance
             ? 2
             : 1;
}

Eigen::MatrixXd term_features(const DiagnosisTerm& term, const StateSignals& states) {
  const Eigen::VectorXd& z = states.of(term.proxy);
  const Eigen::VectorXd& u = states.input;
  switch (term.effect) {
    case Effect::force_factor: {
      // Bl(x) = Bl₀(1 + b₂x²) in the force Bl(x)·i and the back-EMF Bl(x)·v: with i ≈ (u − Bl·v)/Re the
      // force changes by ∝ x²·u and ∝ x²·v (v the change of the state per sample).
      Eigen::MatrixXd g(z.size(), 2);
      g.col(0) = orthogonal_to(orthogonal_to((z.array().square() * u.array()).matrix(), u), z);
      const Eigen::VectorXd v = first_difference(z);
      g.col(1) = orthogonal_to(orthogonal_to((z.array().square() * v.array()).matrix(), v), z);
      return g;
    }
    case Effect::asymmetric_force_factor: {
      // Bl(x) = Bl₀(1 + b₁x), a coil offset: the force changes by ∝ x·u and the back-EMF by ∝ x·v; even
      // harmonics, and a DC part (a DC displacement) which the offset term does not own here: x·u has one.
      Eigen::MatrixXd g(z.size(), 2);
      g.col(0) = orthogonal_to(orthogonal_to((z.array() * u.array()).matrix(), u), z);
      const Eigen::VectorXd v = first_difference(z);
      g.col(1) = orthogonal_to(orthogonal_to((z.array() * v.array()).matrix(), v), z);
      return g;
    }
    case Effect::inductance: {
      // Le(x) (or Le(i) for the input proxy) in Le·di/dt: the current changes by ∝ z·Δu; and the reluctance
      // force ½·i²·dLe/dx ∝ u².
      Eigen::MatrixXd g(z.size(), 2);
      g.col(0) = orthogonal_to(centred_orthogonal_to((z.array() * first_difference(u).array()).matrix(), u), z);
      g.col(1) = centred_orthogonal_to(u.array().square().matrix(), u);
      return g;
    }
    case Effect::saturation:  // the drive as sampled, or behind the drive's filter
      return knee_features(static_nonlinearity_signal(term, states), term.threshold, term.one_sided);
    case Effect::static_nonlinearity: {
      // f(z) with z = front·u: a knee, or z² and z³ (a polynomial of order 3), beyond the linear part
      const Eigen::VectorXd w = static_nonlinearity_signal(term, states);
      if (term.shape == Shape::knee) return knee_features(w, term.threshold, term.one_sided);
      Eigen::MatrixXd g(w.size(), 2);
      g.col(0) = centred_orthogonal_to(w.array().square().matrix(), w);
      g.col(1) = orthogonal_to(w.array().cube().matrix(), w);
      return g;
    }
    default: return term_feature(term, states);
  }
}

Eigen::MatrixXd term_regressors(const DiagnosisTerm& term, const StateSignals& states,
                                const TransferFunction& dynamics, int lags) {
  if (term.effect == Effect::dc_offset) return Eigen::VectorXd::Ones(states.input.size());
  const Eigen::MatrixXd g = term_features(term, states);
  // A static nonlinearity's output (and a saturation's behind the drive's filter) passes only the filter after it;
  // every other term the baseline's dynamics.
  const TransferFunction& through = has_block_filters(term) ? term.back : dynamics;
  const int width = lags + kTermLead;
  Eigen::MatrixXd phi = Eigen::MatrixXd::Zero(g.rows(), width * g.cols());
  for (Eigen::Index j = 0; j < g.cols(); ++j) {
    const Eigen::VectorXd f = filter_through(through, g.col(j));
    for (int l = -kTermLead; l < lags; ++l) {
      const Eigen::Index c = j * width + l + kTermLead, m = f.size() - std::abs(l);
      if (l >= 0) phi.col(c).tail(m) = f.head(m);
      else phi.col(c).head(m) = f.tail(m);
    }
  }
  return phi;
}

int term_columns(const DiagnosisTerm& term, int lags) {
  return term.effect == Effect::dc_offset ? 1 : feature_count(term) * (lags + kTermLead);
}

}  // namespace panelbass::models

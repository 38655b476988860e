#include "models/diagnosis/diagnosis_candidates.h"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <complex>
#include <iomanip>
#include <limits>
#include <numbers>
#include <sstream>

#include "models/linear/linear_identification.h"
#include "models/linear/oe_estimator.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

// Passes in which the terms' states are re-estimated from the augmented output.
constexpr int kRefinements = 2;

// The output of `m` without its terms: the linear simulation, or the baseline's simulation plus the change
// a refit made to its linearisation.
Eigen::VectorXd base_output(const AugmentedModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                            Eigen::Index init) {
  if (!m.simulate_baseline) return m.linear.simulate(u, y, init);
  return m.simulate_baseline(u, y, init) + m.linear.simulate(u) - m.reference.simulate(u);
}

StateSignals reference_of(const AugmentedModel& m) {
  StateSignals s;
  s.mean = m.state_mean;
  s.rms = m.state_rms;
  return s;
}

Eigen::MatrixXd stacked_regressors(const std::vector<DiagnosisTerm>& terms, const StateSignals& states,
                                   const TransferFunction& tf, int lags, Eigen::Index rows) {
  int cols = 0;
  for (const auto& t : terms) cols += term_columns(t, lags);
  Eigen::MatrixXd phi(rows, cols);
  int at = 0;
  for (const auto& t : terms) {
    const int c = term_columns(t, lags);
    phi.middleCols(at, c) = term_regressors(t, states, tf, lags);
    at += c;
  }
  return phi;
}

}  // namespace

// The augmented model's simulation lives here, beside the fit that runs it for every candidate (the same
// states, the same refinement passes).
Eigen::VectorXd simulate_augmented(const AugmentedModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                   Eigen::Index init) {
  const Eigen::VectorXd y_lin = base_output(m, u, y, init);
  if (m.terms.empty()) return y_lin;
  const Eigen::VectorXd ys = m.linear.scaling.scale_y(y_lin);
  // The terms' states come from the simulation started at rest, as on the estimation record: a state set
  // from a few noisy outputs can start a slow transient that the integrals behind the states magnify.
  const Eigen::VectorXd ys_rest = m.linear.scaling.scale_y(base_output(m, u, {}, 0));
  const StateSignals reference = reference_of(m);
  const StateSignals states = state_signals(m.linear.scaling.scale_u(u), ys_rest, m.linear.fs, &reference);
  Eigen::MatrixXd phi = stacked_regressors(m.terms, states, m.linear.tf, m.lags, ys.size());
  Eigen::VectorXd c(phi.cols());
  int at = 0;
  for (const auto& t : m.terms) {
    c.segment(at, t.coefficients.size()) = t.coefficients;
    at += static_cast<int>(t.coefficients.size());
  }
  // y⁽⁰⁾ = ŷ_lin, y⁽ᵏ⁺¹⁾ = ŷ_lin + Φ(y⁽ᵏ⁾)·c: the terms act on the states of the augmented output.
  Eigen::VectorXd y_aug = ys + phi * c;
  for (int pass = 0; pass < kRefinements; ++pass) {
    phi = stacked_regressors(m.terms, state_signals(m.linear.scaling.scale_u(u), ys_rest + phi * c, m.linear.fs, &reference),
                             m.linear.tf, m.lags, ys.size());
    y_aug = ys + phi * c;
  }
  return m.linear.scaling.unscale_y(y_aug);
}

namespace diagnosis_detail {

std::string fixed(double x, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << x;
  return s.str();
}

Fit fit_terms(const Records& r, const LinearModel& linear, std::vector<DiagnosisTerm> terms) {
  Fit f;
  f.model = *r.base;
  f.model.linear = linear;
  f.model.lags = r.lags;
  const Eigen::VectorXd y_lin = linear.scaling.scale_y(base_output(f.model, r.u_est, r.y_est, r.init));
  const Eigen::VectorXd y_rest = linear.scaling.scale_y(base_output(f.model, r.u_est, {}, 0));  // states: see simulate_augmented
  const StateSignals states = state_signals(linear.scaling.scale_u(r.u_est), y_rest, r.fs);
  f.model.state_mean = states.mean;
  f.model.state_rms = states.rms;
  if (!terms.empty()) {
    // Least squares on the regressors of the linear simulation, then refined: the states are re-estimated
    // from the augmented output and the coefficients refitted (kRefinements times; the model's own map).
    const Eigen::VectorXd e = linear.scaling.scale_y(r.y_est) - y_lin;
    Eigen::MatrixXd phi = stacked_regressors(terms, states, linear.tf, r.lags, y_lin.size());
    const Eigen::Index n = phi.rows() - r.init;
    for (int pass = 0; pass <= kRefinements; ++pass) {
      const Eigen::VectorXd c = phi.bottomRows(n).colPivHouseholderQr().solve(e.tail(n));
      int at = 0;
      for (auto& t : terms) {
        const int k = term_columns(t, r.lags);
        t.coefficients = c.segment(at, k);
        at += k;
      }
      if (pass == kRefinements) break;
      const Eigen::VectorXd y_aug = y_rest + phi * c;
      phi = stacked_regressors(terms, state_signals(linear.scaling.scale_u(r.u_est), y_aug, r.fs, &states), linear.tf,
                               r.lags, y_lin.size());
    }
  }
  f.model.terms = std::move(terms);
  f.j_est = j_percent(simulate_augmented(f.model, r.u_est, r.y_est, r.init), r.y_est, r.init);
  f.j_val = j_percent(simulate_augmented(f.model, r.u_val, r.y_val, r.init), r.y_val, r.init);
  return f;
}

std::optional<LinearModel> refit_linear(const Records& r, const LinearModel& base, const TransferFunction& initial,
                                        int iterations) {
  OeOptions o;
  o.max_iterations = iterations;
  o.transient_skip = r.init;
  try {
    const OeResult fit = estimate_oe(base.scaling.scale_u(r.u_est), base.scaling.scale_y(r.y_est), initial, o);
    if (!fit.tf.all_finite() || !fit.tf.is_stable()) return std::nullopt;
    LinearModel m = base;
    m.tf = fit.tf;
    return m;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

namespace {

Eigen::VectorXd convolve(const Eigen::VectorXd& p, const Eigen::VectorXd& q) {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(p.size() + q.size() - 1);
  for (Eigen::Index i = 0; i < p.size(); ++i)
    for (Eigen::Index j = 0; j < q.size(); ++j) out[i + j] += p[i] * q[j];
  return out;
}

// The baseline's pole pair nearest `frequency`: its frequency and damping ratio.
std::pair<double, double> pole_pair_near(const TransferFunction& tf, double frequency, double fs) {
  const std::complex<double> target = std::polar(1.0, 2.0 * std::numbers::pi * frequency / fs);
  const Eigen::VectorXcd poles = tf.poles();
  std::complex<double> best = 0.0;
  double distance = std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 0; k < poles.size(); ++k)
    if (poles[k].imag() > 0.0 && std::abs(poles[k] - target) < distance) distance = std::abs(poles[k] - target), best = poles[k];
  if (best == 0.0) return {0.0, 1.0};
  const std::complex<double> s = std::log(best);
  return {std::abs(s.imag()) * fs / (2.0 * std::numbers::pi), -s.real() / std::abs(s)};
}

// What a refit with an extra pole and zero pair changed against the same structure refitted: the
// frequency (within ±25 % of `near`) where H_after/H_before − 1 is largest, and whether that change
// opposes the response there (real part negative and larger than the quadrature part).
struct PairChange {
  double frequency_hz = 0.0;
  double change_db = 0.0;   ///< 20·log10|H_after/H_before| at that frequency
  double phase_deg = 0.0;   ///< the phase of H_after/H_before − 1
  double bump_db = 0.0;     ///< the largest rise of |H_after/H_before| over the band, dB
  double dip_db = 0.0;      ///< the largest fall, dB (positive)
  bool opposing = false;    ///< a dip that clearly dominates: the model over-predicted in a narrow band
};

PairChange pair_change(const TransferFunction& before, const TransferFunction& after, double near, double fs) {
  PairChange c;
  double largest = -1.0;
  std::complex<double> at = 0.0;
  for (int k = 0; k <= 400; ++k) {
    const double f = near * (0.75 + 0.5 * k / 400.0);
    if (f <= 0.0 || f >= fs / 2.0) continue;
    const std::complex<double> h0 = before.response(f, fs);
    if (std::abs(h0) == 0.0) continue;
    const std::complex<double> ratio = after.response(f, fs) / h0;
    const double db = 20.0 * std::log10(std::max(std::abs(ratio), 1e-300));
    c.bump_db = std::max(c.bump_db, db);
    c.dip_db = std::max(c.dip_db, -db);
    if (std::abs(ratio - 1.0) > largest) largest = std::abs(ratio - 1.0), at = ratio, c.frequency_hz = f;
  }
  const std::complex<double> d = at - 1.0;
  c.change_db = std::abs(at) > 0.0 ? 20.0 * std::log10(std::abs(at)) : 0.0;
  c.phase_deg = std::arg(d) * 180.0 / std::numbers::pi;
  // A mode in quadrature with the response moves its magnitude both ways about equally (dispersion); a
  // missing antiresonance only lowers it.
  c.opposing = c.dip_db > 2.0 * c.bump_db;
  return c;
}

// Correlation of the estimation residual of `fit` with the input `lag` samples earlier.
double lag_correlation(const Records& r, const Fit& fit, int lag) {
  const Eigen::VectorXd e_all = r.y_est - simulate_augmented(fit.model, r.u_est, r.y_est, r.init);
  const Eigen::Index n = r.u_est.size() - r.init - lag;
  if (n < 2) return 0.0;
  const Eigen::VectorXd e = e_all.tail(n).array() - e_all.tail(n).mean();
  const Eigen::VectorXd u = r.u_est.segment(r.init, n).array() - r.u_est.segment(r.init, n).mean();
  const double norm = e.norm() * u.norm();
  return norm > 0.0 ? e.dot(u) / norm : 0.0;
}

/// [2A] on the validation record: the J of `fit`'s simulated output shifted by one sample against itself,
/// Σ (ŷ(k) − ŷ(k−1))² / Σ y² in percent over k ≥ init — what a missing sample of dead time costs.
double one_sample_shift_j(const Records& r, const Fit& fit) {
  const Eigen::VectorXd y_sim = simulate_augmented(fit.model, r.u_val, r.y_val, r.init);
  const Eigen::Index n = r.y_val.size() - r.init;
  const Eigen::Index start = std::max<Eigen::Index>(r.init, 1);
  const Eigen::Index m = r.y_val.size() - start;
  if (n < 2 || m < 1) return 0.0;
  const double energy = r.y_val.tail(n).squaredNorm();
  if (!(energy > 0.0)) return 0.0;
  return 100.0 * (y_sim.tail(m) - y_sim.segment(start - 1, m)).squaredNorm() / energy;
}

/// The share of one_sample_shift_j() a delay refit must recover to be named a dead time.
constexpr double kDelayShareOfShift = 0.25;

DiagnosisTerm term_of(Effect effect, StateProxy proxy, double threshold, double time_constant_s = 0.0) {
  DiagnosisTerm t;
  t.effect = effect;
  t.proxy = proxy;
  t.threshold = threshold;
  t.time_constant_s = time_constant_s;
  return t;
}

// The proxy that estimates the displacement when the output measures `q` (known).
StateProxy displacement_proxy(OutputQuantity q) {
  return q == OutputQuantity::displacement ? StateProxy::output
         : q == OutputQuantity::velocity   ? StateProxy::integral
                                           : StateProxy::double_integral;
}

bool has_effect(const std::vector<DiagnosisTerm>& terms, Effect e) {
  for (const auto& t : terms)
    if (t.effect == e) return true;
  return false;
}


// The baseline's poles in groups that a real filter can hold (a conjugate pair, or a real pole), by frequency.
std::vector<Eigen::VectorXcd> pole_groups(const TransferFunction& tf) {
  const Eigen::VectorXcd poles = tf.poles();
  std::vector<Eigen::VectorXcd> groups;
  for (Eigen::Index k = 0; k < poles.size(); ++k) {
    if (poles[k].imag() < -1e-12) continue;  // its conjugate holds it
    if (poles[k].imag() > 1e-12) {
      Eigen::VectorXcd pair(2);
      pair << poles[k], std::conj(poles[k]);
      groups.push_back(pair);
    } else {
      groups.push_back(Eigen::VectorXcd::Constant(1, std::complex<double>(poles[k].real(), 0.0)));
    }
  }
  std::sort(groups.begin(), groups.end(),
            [](const Eigen::VectorXcd& a, const Eigen::VectorXcd& b) { return std::abs(std::arg(a[0])) < std::abs(std::arg(b[0])); });
  return groups;
}

// The all-pole filter with `roots` as its poles and unit gain at DC.
TransferFunction all_pole(const Eigen::VectorXcd& roots) {
  TransferFunction f;
  const Eigen::VectorXd a = polynomial_from_roots(roots);
  f.a = a.tail(a.size() - 1);
  f.b = Eigen::VectorXd::Constant(1, a.sum());
  return f;
}

// The identity filter (y = x).
TransferFunction identity_filter() {
  TransferFunction f;
  f.b = Eigen::VectorXd::Ones(1);
  return f;
}

// The ways the baseline's dynamics G can be split around a static nonlinearity: all of G after it is the
// input's saturation (not offered here), all before it Wiener; between two filters, the front an all-pole
// filter of some of G's pole groups and the back the rest with G's zeros and delay (Wiener–Hammerstein).
// With up to five groups every split; with more, the lowest and the highest k groups in front.
std::vector<std::pair<TransferFunction, TransferFunction>> block_splits(const TransferFunction& tf) {
  std::vector<std::pair<TransferFunction, TransferFunction>> out;
  out.emplace_back(tf, identity_filter());  // Wiener
  const std::vector<Eigen::VectorXcd> groups = pole_groups(tf);
  const std::size_t g = groups.size();
  if (g < 2) return out;
  std::vector<std::vector<bool>> subsets;
  if (g <= 5) {
    for (unsigned mask = 1; mask + 1 < (1u << g); ++mask) {
      std::vector<bool> in(g);
      for (std::size_t k = 0; k < g; ++k) in[k] = (mask >> k) & 1u;
      subsets.push_back(in);
    }
  } else {
    for (std::size_t k = 1; k < g; ++k) {
      std::vector<bool> low(g, false), high(g, false);
      for (std::size_t j = 0; j < k; ++j) low[j] = true, high[g - 1 - j] = true;
      subsets.push_back(low);
      subsets.push_back(high);
    }
  }
  for (const auto& in : subsets) {
    std::vector<std::complex<double>> front, back;
    for (std::size_t k = 0; k < g; ++k)
      for (Eigen::Index j = 0; j < groups[k].size(); ++j) (in[k] ? front : back).push_back(groups[k][j]);
    TransferFunction b = all_pole(Eigen::Map<Eigen::VectorXcd>(back.data(), static_cast<Eigen::Index>(back.size())));
    b.b = tf.b;
    b.nk = tf.nk;
    out.emplace_back(all_pole(Eigen::Map<Eigen::VectorXcd>(front.data(), static_cast<Eigen::Index>(front.size()))), b);
  }
  return out;
}

// A fitted static nonlinearity's shape from its coefficients: the static curve is front_rms·z (the linear
// path through the back filter) plus Σ_l c_l times each feature; the slope beyond the knee over the slope
// inside it, per side. Below 1: saturating; above: dead-zone-like (the gain rises past the knee).
nlohmann::json static_shape(const DiagnosisTerm& t, const StateSignals& states, int lags) {
  const Eigen::VectorXd z = static_nonlinearity_signal(t, states);
  const int width = lags + kTermLead;
  if (t.shape == Shape::polynomial) {
    const double c3 = t.coefficients.segment(width, width).sum();
    return {{"shape", "polynomial"}, {"polynomial_order", 3}, {"compressive", c3 * t.front_rms < 0.0}};
  }
  // The features are the raw knees minus β·z (orthogonalised): the slope inside is front_rms − Σ_j C_j·β_j.
  const Eigen::Index sides = t.one_sided ? 2 : 1;
  Eigen::VectorXd sums(sides), betas(sides);
  for (Eigen::Index j = 0; j < sides; ++j) {
    Eigen::VectorXd raw(z.size());
    for (Eigen::Index k = 0; k < z.size(); ++k)
      raw[k] = !t.one_sided ? std::max(std::abs(z[k]) - t.threshold, 0.0) * (z[k] < 0 ? -1.0 : 1.0)
                            : j == 0 ? std::max(z[k] - t.threshold, 0.0) : std::min(z[k] + t.threshold, 0.0);
    betas[j] = z.dot(raw) / std::max(z.squaredNorm(), 1e-300);
    sums[j] = t.coefficients.segment(j * width, width).sum();
  }
  const double inside = t.front_rms - sums.dot(betas);
  nlohmann::json ratios = nlohmann::json::array();
  bool falls = false, rises = false;
  for (Eigen::Index j = 0; j < sides; ++j) {
    const double ratio = (inside + sums[j]) / inside;
    ratios.push_back(ratio);
    falls = falls || ratio < 0.9;
    rises = rises || ratio > 1.1;
  }
  const std::string word = falls && !rises ? "saturating" : rises && !falls ? "dead zone" : falls ? "mixed" : "nearly linear";
  return {{"shape", word}, {"slope_beyond_knee_over_inside", ratios}};
}

}  // namespace

void static_nonlinearity_candidates(const Records& r, const Fit& current, const std::function<void(Candidate)>& offer) {
  if (has_effect(current.model.terms, Effect::static_nonlinearity)) return;
  const LinearModel& linear = current.model.linear;
  const StateSignals states = state_signals(linear.scaling.scale_u(r.u_est), linear.scaling.scale_u(r.u_est), r.fs);
  const double n_val = static_cast<double>(r.u_val.size() - r.init);
  auto fitted = [&](DiagnosisTerm t, int choices) {
    std::vector<DiagnosisTerm> with = current.model.terms;
    with.push_back(t);
    return Candidate{Effect::static_nonlinearity, "", term_columns(t, r.lags) + choices, fit_terms(r, linear, with), {}};
  };
  auto score = [&](const Candidate& c) { return n_val * std::log(current.j_val / c.fit.j_val) - c.parameters * std::log(n_val); };
  // Each split screened with one shape (a knee at half the peak, each side on its own); the best split then
  // gets every shape. The split and the knee are choices made from the data: a parameter each.
  std::optional<Candidate> best;
  DiagnosisTerm best_term;
  for (const auto& [front, back] : block_splits(linear.tf)) {
    DiagnosisTerm t;
    t.effect = Effect::static_nonlinearity;
    t.position = back.a.size() == 0 && back.nk == 0 && back.b.size() == 1 ? Position::output : Position::between;
    t.front = front;
    t.back = back;
    const Eigen::VectorXd w = filter_through(front, states.input);
    t.front_rms = std::sqrt(w.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, w.size())));
    if (!(t.front_rms > 0.0) || !std::isfinite(t.front_rms)) continue;
    t.one_sided = true;
    t.threshold = 0.5 * (w / t.front_rms).cwiseAbs().maxCoeff();
    Candidate c = fitted(t, 3);
    if (!best || score(c) > score(*best)) best = std::move(c), best_term = t;
  }
  if (!best) return;
  const double peak = static_nonlinearity_signal(best_term, states).cwiseAbs().maxCoeff();
  std::vector<DiagnosisTerm> shapes;
  for (bool one_sided : {false, true})
    for (double fraction : {0.2, 0.35, 0.5, 0.65, 0.8}) {
      DiagnosisTerm t = best_term;
      t.one_sided = one_sided;
      t.threshold = fraction * peak;
      shapes.push_back(t);
    }
  DiagnosisTerm poly = best_term;
  poly.shape = Shape::polynomial;
  shapes.push_back(poly);
  for (const auto& t : shapes) {
    Candidate c = fitted(t, t.shape == Shape::knee ? 3 : 2);
    const DiagnosisTerm& kept = c.fit.model.terms.back();
    const std::string where = t.position == Position::output ? "output" : "between";
    c.variant = std::string(where == "output" ? "Wiener" : "Wiener–Hammerstein") + ", " +
                (t.shape == Shape::polynomial ? std::string("polynomial")
                                              : std::string(t.one_sided ? "each side" : "both sides") + ", knee " +
                                                    fixed(t.threshold / peak, 2));
    c.parameters_json = static_shape(kept, states, r.lags);
    c.parameters_json["position"] = where;
    c.parameters_json["structure"] = where == "output" ? "Wiener" : "Wiener–Hammerstein";
    c.parameters_json["front_order"] = t.front.na();
    c.parameters_json["back_order"] = t.back.na();
    if (t.shape == Shape::knee) {
      c.parameters_json["knee_fraction_of_peak"] = t.threshold / peak;
      c.parameters_json["one_sided"] = t.one_sided;
    }
    offer(std::move(c));
  }
}

std::vector<Candidate> candidates(const Records& r, const Fit& current, const ResidualLocation& where,
                                  int oe_iterations) {
  std::vector<Candidate> best;
  // Of the variants of one effect, the one with the best BIC score against `current` is kept.
  const double n_val = static_cast<double>(r.u_val.size() - r.init);
  auto score = [&](const Candidate& c) { return n_val * std::log(current.j_val / c.fit.j_val) - c.parameters * std::log(n_val); };
  auto offer = [&](Candidate c) {
    for (auto& b : best)
      if (b.effect == c.effect) {
        if (score(c) > score(b)) b = std::move(c);
        return;
      }
    best.push_back(std::move(c));
  };
  const LinearModel& linear = current.model.linear;
  const std::vector<DiagnosisTerm>& terms = current.model.terms;

  // A term's parameters: its coefficients, and one for the choice made from the data (state, knee, τ).
  auto add_term = [&](DiagnosisTerm t, const std::string& variant, int choices, nlohmann::json params) {
    if (has_effect(terms, t.effect)) return;
    const int parameters = term_columns(t, r.lags) + choices;
    std::vector<DiagnosisTerm> with = terms;
    with.push_back(t);
    Candidate c{t.effect, variant, parameters, fit_terms(r, linear, with), std::move(params)};
    offer(std::move(c));
  };
  add_term(term_of(Effect::dc_offset, StateProxy::output, 0.0), "constant", 0, nlohmann::json::object());
  // A state proxy is one more choice made from the data: one parameter. With the output's quantity known,
  // the forces of the motion act on the displacement's proxy only (the velocity is its rate of change): a
  // cubic spring and a nonlinear damping are then different functions, not the cube of one signal.
  for (StateProxy p : {StateProxy::output, StateProxy::integral, StateProxy::double_integral}) {
    if (r.output != OutputQuantity::unknown && p != displacement_proxy(r.output)) continue;
    add_term(term_of(Effect::cubic_stiffness, p, 0.0), to_string(p), 1, {{"state", to_string(p)}});
    add_term(term_of(Effect::asymmetric_stiffness, p, 0.0), to_string(p), 1, {{"state", to_string(p)}});
    add_term(term_of(Effect::hysteresis, p, 0.0), to_string(p), 1, {{"state", to_string(p)}});
    add_term(term_of(Effect::force_factor, p, 0.0), to_string(p), 1, {{"state", to_string(p)}});
  }
  for (StateProxy p : {StateProxy::output, StateProxy::integral, StateProxy::double_integral, StateProxy::input})
    add_term(term_of(Effect::inductance, p, 0.0), to_string(p), 1, {{"state", to_string(p)}});
  // Thermal time constants (seconds) that fit at least four times into the estimation record.
  for (double tau : {0.5, 2.0, 8.0})
    if (4.0 * tau * r.fs <= static_cast<double>(r.u_est.size()))
      add_term(term_of(Effect::thermal_compression, StateProxy::input, 0.0, tau), "tau " + fixed(tau, 1) + " s",
               1, {{"time_constant_s", tau}});
  {
    // Saturation of the drive, both sides alike (an amplifier) or each on its own (a diode); knees at
    // fractions of the normalised input's peak on the estimation record.
    const Eigen::VectorXd z = state_signals(linear.scaling.scale_u(r.u_est), linear.scaling.scale_u(r.u_est), r.fs).input;
    const double peak = z.cwiseAbs().maxCoeff();
    for (bool one_sided : {false, true})
      for (double fraction : {0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.93, 0.95, 0.97, 0.99}) {
        DiagnosisTerm t = term_of(Effect::saturation, StateProxy::input, fraction * peak);
        t.one_sided = one_sided;
        add_term(t, std::string(one_sided ? "each side" : "both sides") + ", knee " + fixed(fraction, 2), 1,
                 {{"knee_fraction_of_peak", fraction}, {"one_sided", one_sided}});
      }
  }
  static_nonlinearity_candidates(r, current, offer);
  // The linear refits below are judged against the same structure refitted on the same record, so that
  // what a refit gains by itself (a given baseline from other data) is credited to no effect.
  const TransferFunction& tf = linear.tf;
  const std::optional<LinearModel> same = refit_linear(r, linear, tf, oe_iterations);
  const double j_same = same ? fit_terms(r, *same, terms).j_val : current.j_val;
  // Delay: one sample more of dead time (the first numerator coefficient dropped), or one sample less (a
  // coefficient added in front, so the baseline is the special case b₀ = 0: one parameter more), then OE.
  // One sample less is tried only when the residual correlates with the input at that lag (3 standard
  // errors): otherwise the added coefficient is merely a free zero, fitting whatever else is missing.
  const bool early_response = tf.nk > 0 && std::abs(lag_correlation(r, current, tf.nk - 1)) >
                                               3.0 / std::sqrt(static_cast<double>(r.u_est.size() - r.init));
  // One sample more is not nested (b₀ dropped, a coefficient gained at the tail), so it needs its own
  // evidence: a sample of dead time missing misaligns the whole response, and the residual then carries
  // what a one-sample shift of the simulated output would, J_shift = Σ (ŷ(k) − ŷ(k−1))² / Σ y² [2A]. A
  // refit that recovers only a small part of that traded a real first coefficient (a converter's small
  // first sample) for one at the tail: that is the numerator's length, which the order scan owns.
  const double j_shift = one_sample_shift_j(r, current);
  for (int step : {+1, -1}) {
    if (tf.nk + step < 0 || tf.nb() < 2 || (step < 0 && !early_response)) continue;
    TransferFunction init = tf;
    init.nk = tf.nk + step;
    if (step > 0) {
      init.b = Eigen::VectorXd::Zero(tf.nb());
      init.b.head(tf.nb() - 1) = tf.b.tail(tf.nb() - 1);
    } else {
      init.b = Eigen::VectorXd::Zero(tf.nb() + 1);
      init.b.tail(tf.nb()) = tf.b;
    }
    if (auto m = refit_linear(r, linear, init, oe_iterations)) {
      Fit f = fit_terms(r, *m, terms);
      const double recovered = current.j_val - f.j_val;
      if (f.j_val < j_same && (step < 0 || recovered >= kDelayShareOfShift * j_shift))
        offer({Effect::delay, "nk " + std::to_string(init.nk), 1, std::move(f),
               {{"nk_before", tf.nk}, {"nk_after", init.nk}, {"shift_j_pct", j_shift}, {"j_recovered_pct", recovered}}});
    }
  }
  // Resonance or antiresonance: a pole pair and a zero pair (cancelling at the start, so the start is the
  // baseline's response) at the residual's spectral peak, then OE moves both. What the pair does decides
  // the name: against the same structure refitted, a change in quadrature with the response (a mode
  // adding its own motion) is a resonance; one opposing the response (the model over-predicting in a
  // narrow band) an antiresonance.
  if (where.peak_frequency_hz > 0.0 && same) {
    // Three starts, since OE from one tends to stay on one side of the peak: the pairs cancelling, a
    // shallow peak and a shallow dip; the refit that fits the estimation record best is kept.
    const double theta = 2.0 * std::numbers::pi * where.peak_frequency_hz / r.fs;
    auto pair_at = [theta](double radius) {
      Eigen::VectorXd pair(3);
      pair << 1.0, -2.0 * radius * std::cos(theta), radius * radius;
      return pair;
    };
    Eigen::VectorXd a_full(tf.na() + 1);
    a_full << 1.0, tf.a;
    std::optional<LinearModel> refitted;
    double best_j = std::numeric_limits<double>::infinity();
    for (const auto& [pole_radius, zero_radius] : {std::pair{0.98, 0.98}, std::pair{0.99, 0.97}, std::pair{0.97, 0.99}}) {
      TransferFunction init = tf;
      init.a = convolve(a_full, pair_at(pole_radius)).tail(tf.na() + 2);
      init.b = convolve(tf.b, pair_at(zero_radius));
      if (auto m = refit_linear(r, linear, init, oe_iterations)) {
        const double j = simulation_j_percent(*m, r.u_est, r.y_est, r.init);
        if (j < best_j) best_j = j, refitted = std::move(m);
      }
    }
    Fit fitted;
    if (refitted) fitted = fit_terms(r, *refitted, terms);
    if (refitted) {
      const PairChange change = pair_change(tf, refitted->tf, where.peak_frequency_hz, r.fs);
      const auto [f, zeta] = pole_pair_near(refitted->tf, change.frequency_hz, r.fs);
      const Effect effect = change.opposing ? Effect::antiresonance : Effect::resonance;
      offer({effect, "pole and zero pair", 4, std::move(fitted),
             {{"frequency_hz", change.frequency_hz},
              {"pole_frequency_hz", f},
              {"pole_damping_ratio", zeta},
              {"change_db", change.change_db},
              {"change_phase_deg", change.phase_deg},
              {"bump_db", change.bump_db},
              {"dip_db", change.dip_db},
              {"order_before", tf.na()},
              {"order_after", tf.na() + 2}}});
    }
  }
  return best;
}

DistortionParity distortion_parity(const Candidate& c) {
  switch (c.effect) {
    case Effect::cubic_stiffness:      // x³
    case Effect::force_factor:         // x²·u, x²·v
    case Effect::hysteresis:           // sign of the motion: odd
    case Effect::nonlinear_damping:    // v³
    case Effect::thermal_compression:  // the drive times its (even) power
      return DistortionParity::odd;
    case Effect::asymmetric_stiffness:     // x²
    case Effect::asymmetric_force_factor:  // x·u, x·v
      return DistortionParity::even;
    case Effect::saturation:
      return c.parameters_json.value("one_sided", false) ? DistortionParity::both : DistortionParity::odd;
    case Effect::static_nonlinearity:  // a two-sided knee is odd; one side alone or a polynomial with z² both
      return c.parameters_json.value("shape", "") != "polynomial" && !c.parameters_json.value("one_sided", true)
                 ? DistortionParity::odd
                 : DistortionParity::both;
    case Effect::inductance:  // z·Δu and u²
      return DistortionParity::both;
    case Effect::resonance:
    case Effect::antiresonance:
    case Effect::delay:
    case Effect::dc_offset:
      return DistortionParity::none;
  }
  return DistortionParity::both;
}

std::string ruled_out_by_periodic_distortion(const Candidate& c, const PeriodicDistortion& residual) {
  if (!residual.periodic || !residual.odd_lines_only || std::isnan(residual.residual_odd_db) ||
      std::isnan(residual.residual_even_db))
    return "";
  const bool odd_seen = residual.residual_odd_db > residual.threshold_db;
  const bool even_seen = residual.residual_even_db > residual.threshold_db;
  const DistortionParity parity = distortion_parity(c);
  if (parity == DistortionParity::even && odd_seen && !even_seen)
    return "the residual shows odd distortion (" + fixed(residual.residual_odd_db, 1) + " dB over its noise at the empty odd lines) "
           "but none at the empty even lines (" + fixed(residual.residual_even_db, 1) + " dB): an even-order term cannot be what is missing";
  if (parity == DistortionParity::odd && even_seen && !odd_seen)
    return "the residual shows even distortion (" + fixed(residual.residual_even_db, 1) + " dB over its noise at the empty even lines) "
           "but none at the empty odd lines (" + fixed(residual.residual_odd_db, 1) + " dB): an odd-order term cannot be what is missing";
  return "";
}

}  // namespace diagnosis_detail
}  // namespace panelbass::models

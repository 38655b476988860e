#include "models/diagnosis/diagnosis.h"

#include <Eigen/QR>
#include <cmath>
#include <complex>
#include <iomanip>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "dsp/excitation.h"
#include "models/linear/linear_identification.h"
#include "models/linear/oe_estimator.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

// Passes in which the terms' states are re-estimated from the augmented output.
constexpr int kRefinements = 2;

struct Records {
  const Eigen::VectorXd& u_est;
  const Eigen::VectorXd& y_est;
  const Eigen::VectorXd& u_val;
  const Eigen::VectorXd& y_val;
  double fs;
  Eigen::Index init;
  int lags;
  const AugmentedModel* base = nullptr;  ///< the simulation diagnosed (its linear part and, if not linear, its simulation)
};

// The output of `m` without its terms: the linear simulation, or the baseline's simulation plus the change
// a refit made to its linearisation.
Eigen::VectorXd base_output(const AugmentedModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                            Eigen::Index init) {
  if (!m.simulate_baseline) return m.linear.simulate(u, y, init);
  return m.simulate_baseline(u, y, init) + m.linear.simulate(u) - m.reference.simulate(u);
}

// An augmented model with its coefficients fitted, and its simulation J on both records.
struct Fit {
  AugmentedModel model;
  double j_est = 0.0;
  double j_val = 0.0;
};

// One candidate augmentation, fitted.
struct Candidate {
  Effect effect = Effect::dc_offset;
  std::string variant;
  int parameters = 0;
  Fit fit;
  nlohmann::json parameters_json = nlohmann::json::object();
};

std::string fixed(double x, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << x;
  return s.str();
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

// Fits the coefficients of `terms` by least squares on the estimation residual of `linear`'s simulation
// and simulates the result on both records.
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

// `base` refitted by OE from `initial` on the estimation record (nothing if the fit fails).
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

DiagnosisTerm term_of(Effect effect, StateProxy proxy, double threshold, double time_constant_s = 0.0) {
  DiagnosisTerm t;
  t.effect = effect;
  t.proxy = proxy;
  t.threshold = threshold;
  t.time_constant_s = time_constant_s;
  return t;
}

bool has_effect(const std::vector<DiagnosisTerm>& terms, Effect e) {
  for (const auto& t : terms)
    if (t.effect == e) return true;
  return false;
}

// Every candidate augmentation of `current`, fitted; the best variant of each effect is kept.
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
  // A state proxy is one more choice made from the data: one parameter.
  for (StateProxy p : {StateProxy::output, StateProxy::integral, StateProxy::double_integral}) {
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
      if (f.j_val < j_same)
        offer({Effect::delay, "nk " + std::to_string(init.nk), 1, std::move(f), {{"nk_before", tf.nk}, {"nk_after", init.nk}}});
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

// Correlation of the estimation residual of `before` with what `after` adds to it.
double added_correlation(const Records& r, const Fit& before, const Fit& after) {
  const Eigen::VectorXd y0 = simulate_augmented(before.model, r.u_est, r.y_est, r.init);
  const Eigen::VectorXd y1 = simulate_augmented(after.model, r.u_est, r.y_est, r.init);
  const Eigen::Index n = y0.size() - r.init;
  const Eigen::VectorXd e = (r.y_est - y0).tail(n), d = (y1 - y0).tail(n);
  const double norm = e.norm() * d.norm();
  return norm > 0.0 ? e.dot(d) / norm : 0.0;
}

std::string explain(const Candidate& c, const ResidualLocation& where, double correlation) {
  std::string state = c.parameters_json.contains("state") ? c.parameters_json["state"].get<std::string>() : "";
  if (state == "integral") state = "integral of the output (a velocity, for an accelerometer)";
  if (state == "double_integral") state = "double integral of the output (a displacement, for an accelerometer)";
  const std::string r = fixed(correlation, 2);
  switch (c.effect) {
    case Effect::dc_offset:
      return "The model leaves out a DC offset in the drive or the sensor: the residual mean is " + fixed(where.mean, 4) +
             ", " + fixed(std::abs(where.mean_t), 1) + " standard errors from zero.";
    case Effect::delay:
      return "The model leaves out " + std::string(c.parameters_json["nk_after"].get<int>() > c.parameters_json["nk_before"].get<int>() ? "a sample more" : "a sample less") +
             " of dead time: the input–residual cross-correlation peaks at lag " + std::to_string(where.xcorr_lag) +
             " and refitting with nk = " + std::to_string(c.parameters_json["nk_after"].get<int>()) + " removes it.";
    case Effect::resonance:
      return "The model leaves out a lightly damped mode near " + fixed(c.parameters_json["frequency_hz"].get<double>(), 0) +
             " Hz: the residual spectrum peaks at " + fixed(where.peak_frequency_hz, 0) + " Hz (" +
             fixed(where.peak_over_noise, 2) + " times the noise floor), and an extra pole pair there, adding motion in "
             "quadrature with the response (" + fixed(c.parameters_json["change_phase_deg"].get<double>(), 0) + "°), explains it.";
    case Effect::antiresonance:
      return "The model leaves out an antiresonance near " + fixed(c.parameters_json["frequency_hz"].get<double>(), 0) +
             " Hz (modes cancelling): the model over-predicts there by " +
             fixed(c.parameters_json["dip_db"].get<double>(), 2) + " dB, the residual spectrum peaks at " +
             fixed(where.peak_frequency_hz, 0) + " Hz, and a zero pair with its pole pair fills the dip.";
    case Effect::cubic_stiffness:
      return "The model leaves out a cubic stiffness (a spring that hardens or softens with excursion): the residual "
             "follows the cube of the estimated " + state + " (odd and level-dependent; correlation " + r + ").";
    case Effect::asymmetric_stiffness:
      return "The model leaves out an asymmetric stiffness: the residual follows the square of the estimated " + state +
             " (even-order; correlation " + r + ").";
    case Effect::hysteresis:
      return "The model leaves out friction or hysteresis: the residual follows the direction of motion of the estimated " +
             state + " rather than its position (correlation " + r + ").";
    case Effect::saturation:
      return std::string(c.parameters_json["one_sided"].get<bool>()
                             ? "The model leaves out a saturation that differs between the two directions (diode-like): "
                             : "The model leaves out a saturation (clipping) alike in both directions: ") +
             "the residual follows the input beyond " + fixed(c.parameters_json["knee_fraction_of_peak"].get<double>() * 100.0, 0) +
             " % of its peak and is " + fixed(where.level_ratio, 1) + " times larger at high input level than at low.";
    case Effect::force_factor:
      return "The model leaves out a force factor that falls with excursion (the coil leaving the gap): the residual "
             "follows the drive times the square of the estimated " + state + " (odd, intermodulating; correlation " + r + ").";
    case Effect::inductance:
      return std::string("The model leaves out an inductance that varies with ") +
             (c.parameters_json["state"] == "input" ? "the current" : "excursion") +
             ": the residual follows the estimated " + (c.parameters_json["state"] == "input" ? std::string("drive") : state) +
             " times the rate of change of the drive (an i·di/dt-type term, strongest above resonance; correlation " + r + ").";
    case Effect::thermal_compression:
      return "The model leaves out thermal compression (the coil resistance rising with dissipated power): the residual "
             "follows the drive times its power averaged over " + fixed(c.parameters_json["time_constant_s"].get<double>(), 1) +
             " s (the gain changed by " + fixed(where.gain_drift * 100.0, 2) + " % between the first and the last quarter; correlation " + r + ").";
    default: return "The model leaves out " + to_string(c.effect) + ".";
  }
}

nlohmann::json terms_json(const AugmentedModel& m) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& t : m.terms)
    out.push_back({{"effect", to_string(t.effect)},
                   {"state", to_string(t.proxy)},
                   {"threshold", t.threshold},
                   {"time_constant_s", t.time_constant_s},
                   {"one_sided", t.one_sided},
                   {"coefficients", std::vector<double>(t.coefficients.data(), t.coefficients.data() + t.coefficients.size())}});
  return out;
}

void check_record(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const std::string& name, Eigen::Index init) {
  if (u.size() != y.size())
    throw std::invalid_argument("diagnose: " + name + " record: input has " + std::to_string(u.size()) +
                                " samples, output " + std::to_string(y.size()));
  if (u.size() < init + 512)
    throw std::invalid_argument("diagnose: " + name + " record: " + std::to_string(u.size()) +
                                " samples; at least " + std::to_string(init + 512) + " needed");
  if (!u.allFinite() || !y.allFinite()) throw std::invalid_argument("diagnose: " + name + " record: a sample is not finite");
}

}  // namespace

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

namespace {

// The OE model with the lowest validation J over the order scan of `options`, from (u_est, y_est) and
// judged on (u_val, y_val), and the scan as JSON.
std::pair<LinearModel, nlohmann::json> best_linear(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est,
                                                   const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, double fs,
                                                   const DiagnosisOptions& options) {
  LinearIdentificationSpec spec;
  spec.method = LinearMethod::oe;
  spec.fs = fs;
  spec.init = options.init;
  spec.order = options.scan_to;
  spec.scan_from = options.scan_from;
  spec.scan_to = options.scan_to;
  LinearIdentification id = identify_linear(u_est, y_est, u_val, y_val, spec);
  // The order with the lowest validation J (the scan's own rule allows 5 % more, which would leave
  // a dynamic mismatch for the diagnosis to find).
  int best_order = id.model.tf.na();
  double best_j = std::numeric_limits<double>::infinity();
  for (const auto& e : id.scan)
    if (e.j_val_pct < best_j) best_j = e.j_val_pct, best_order = e.order;
  nlohmann::json scan = nlohmann::json::array();
  for (const auto& e : id.scan) scan.push_back({{"order", e.order}, {"J_val_pct", e.j_val_pct}});
  if (best_order != id.model.tf.na()) {
    spec.scan_from = spec.scan_to = 0;
    spec.order = best_order;
    id = identify_linear(u_est, y_est, u_val, y_val, spec);
  }
  return {id.model, scan};
}

void check_arguments(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val,
                     const Eigen::VectorXd& y_val, double fs, const DiagnosisOptions& options) {
  if (!(fs > 0.0) || !std::isfinite(fs)) throw std::invalid_argument("diagnose: sample rate " + std::to_string(fs) + " Hz is not positive");
  if (options.init < 0) throw std::invalid_argument("diagnose: init must not be negative");
  if (options.lags < 1) throw std::invalid_argument("diagnose: lags must be at least 1");
  check_record(u_est, y_est, "estimation", options.init);
  check_record(u_val, y_val, "validation", options.init);
}

// The rounds of a diagnosis from the baseline r.base: locate, score the candidates, keep the best while
// its BIC score is positive.
void run_rounds(const Records& r, const DiagnosisOptions& options, Diagnosis& d) {
  const auto progress = [&](const std::string& stage) {
    if (options.progress) options.progress(stage);
  };
  const Eigen::VectorXd &u_est = r.u_est, &y_est = r.y_est, &u_val = r.u_val, &y_val = r.y_val;
  const double fs = r.fs;
  progress("locating the residual of the baseline");
  Fit current = fit_terms(r, r.base->linear, {});
  d.baseline_model = current.model;
  d.baseline_j_val_pct = current.j_val;
  d.baseline_j_est_pct = current.j_est;
  d.j_val_before_pct = current.j_val;
  d.located_est = locate_residual(u_est, y_est, simulate_augmented(current.model, u_est, y_est, r.init), fs, r.init);
  d.located_val = locate_residual(u_val, y_val, simulate_augmented(current.model, u_val, y_val, r.init), fs, r.init);
  d.noise_floor_pct = d.located_val.noise_floor_pct;
  const double n_val = static_cast<double>(u_val.size() - r.init);
  for (int round = 0; round < options.max_findings; ++round) {
    progress("round " + std::to_string(round + 1) + ": scoring candidate effects");
    const ResidualLocation where_est =
        locate_residual(u_est, y_est, simulate_augmented(current.model, u_est, y_est, r.init), fs, r.init);
    const ResidualLocation where_val =
        locate_residual(u_val, y_val, simulate_augmented(current.model, u_val, y_val, r.init), fs, r.init);
    std::vector<Candidate> scored = candidates(r, current, where_est, options.oe_iterations);
    // BIC on the validation residual: N·ln(J_before/J_after) − p·ln(N) > 0 to be kept.
    const Candidate* chosen = nullptr;
    double best_score = 0.0;
    nlohmann::json round_json = nlohmann::json::array();
    for (const auto& c : scored) {
      const double score = n_val * std::log(current.j_val / c.fit.j_val) - c.parameters * std::log(n_val);
      round_json.push_back({{"effect", to_string(c.effect)}, {"variant", c.variant}, {"parameters", c.parameters},
                            {"J_val_pct", c.fit.j_val}, {"score", score}});
      if (score > best_score) best_score = score, chosen = &c;
    }
    d.rounds.push_back(round_json);
    if (chosen == nullptr) break;
    const double correlation = added_correlation(r, current, chosen->fit);
    Finding f;
    f.effect = chosen->effect;
    f.added_parameters = chosen->parameters;
    f.j_val_before_pct = current.j_val;
    f.j_val_after_pct = chosen->fit.j_val;
    f.explanation = explain(*chosen, where_est, correlation);
    f.evidence = {{"score_bic", best_score},
                  {"added_correlation", correlation},
                  {"J_est_before_pct", current.j_est},
                  {"J_est_after_pct", chosen->fit.j_est},
                  {"residual_estimation", location_to_json(where_est)},
                  {"residual_validation", location_to_json(where_val)}};
    f.parameters = chosen->parameters_json;
    f.parameters["added"] = chosen->parameters;
    f.parameters["terms"] = terms_json(chosen->fit.model);
    progress("found " + to_string(f.effect) + ": validation J " + fixed(f.j_val_before_pct, 3) + " % → " +
             fixed(f.j_val_after_pct, 3) + " %");
    d.findings.push_back(std::move(f));
    current = chosen->fit;
  }
  d.j_val_after_pct = current.j_val;
  d.at_noise_floor = at_noise_floor(d.j_val_after_pct, d.noise_floor_pct);
  d.located_val_after = locate_residual(u_val, y_val, simulate_augmented(current.model, u_val, y_val, r.init), fs, r.init);
  d.model = current.model;
}

// `simulate` with its results kept per record (input and output data, length, init): a diagnosis simulates
// the same two records for every candidate, and a plant simulation is costly.
RecordSimulation remembered(RecordSimulation simulate) {
  struct Entry {
    const double* u;
    const double* y;
    Eigen::Index size, init;
    double u_sum;
    Eigen::VectorXd output;
  };
  auto entries = std::make_shared<std::vector<Entry>>();
  return [simulate = std::move(simulate), entries](const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) {
    const double sum = u.sum();
    for (const Entry& e : *entries)
      if (e.u == u.data() && e.y == y.data() && e.size == u.size() && e.init == init && e.u_sum == sum) return e.output;
    Eigen::VectorXd output = simulate(u, y, init);
    if (output.size() != u.size() || !output.allFinite())
      throw std::invalid_argument("diagnose: the baseline's simulation of " + std::to_string(u.size()) +
                                  " samples is not finite or not as long as its input");
    entries->push_back({u.data(), y.data(), u.size(), init, sum, output});
    return output;
  };
}

}  // namespace

Diagnosis diagnose(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val,
                   const Eigen::VectorXd& y_val, double fs, const std::optional<LinearModel>& baseline,
                   const DiagnosisOptions& options) {
  check_arguments(u_est, y_est, u_val, y_val, fs, options);
  Records r{u_est, y_est, u_val, y_val, fs, options.init, options.lags};
  Diagnosis d;
  LinearModel linear;
  if (baseline) {
    linear = *baseline;
    if (std::abs(linear.fs - fs) > 1e-6 * fs)
      throw std::invalid_argument("diagnose: the model was identified at " + std::to_string(linear.fs) +
                                  " Hz but the data is at " + std::to_string(fs) + " Hz");
    d.baseline_info = {{"source", "given"}, {"method", linear.method}, {"na", linear.tf.na()}, {"nb", linear.tf.nb()}, {"nk", linear.tf.nk}};
  } else {
    if (options.progress)
      options.progress("identifying the best linear model (OE, orders " + std::to_string(options.scan_from) + ".." +
                       std::to_string(options.scan_to) + ")");
    nlohmann::json scan;
    std::tie(linear, scan) = best_linear(u_est, y_est, u_val, y_val, fs, options);
    // The delay estimated from the data is the first *visible* one; a converter's latency often leaves
    // a small first sample before it, so one sample less is tried too and kept if validation J says so.
    const int nk_estimated = linear.tf.nk;
    if (linear.tf.nk > 0 && linear.tf.nb() >= 2) {
      if (options.progress) options.progress("trying one sample less of delay than estimated");
      TransferFunction shorter = linear.tf;
      shorter.nk -= 1;
      shorter.b = Eigen::VectorXd::Zero(linear.tf.nb());
      shorter.b.tail(linear.tf.nb() - 1) = linear.tf.b.head(linear.tf.nb() - 1);
      if (auto m = refit_linear(r, linear, shorter, options.oe_iterations))
        if (simulation_j_percent(*m, u_val, y_val, r.init) < simulation_j_percent(linear, u_val, y_val, r.init)) linear = *m;
    }
    d.baseline_info = {{"source", "identified"}, {"method", "oe"}, {"na", linear.tf.na()}, {"nb", linear.tf.nb()},
                       {"nk", linear.tf.nk}, {"nk_estimated", nk_estimated},
                       {"order_rule", "lowest validation J over the scan, then nk or nk − 1 by validation J"}, {"scan", scan}};
  }
  AugmentedModel base;
  base.linear = linear;
  r.base = &base;
  run_rounds(r, options, d);
  return d;
}

Diagnosis diagnose(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val,
                   const Eigen::VectorXd& y_val, double fs, const SimulationBaseline& baseline,
                   const DiagnosisOptions& options) {
  check_arguments(u_est, y_est, u_val, y_val, fs, options);
  if (!baseline.simulate) throw std::invalid_argument("diagnose: the " + baseline.kind + " baseline has no simulation");
  if (std::abs(baseline.fs - fs) > 1e-6 * fs)
    throw std::invalid_argument("diagnose: the " + baseline.kind + " baseline runs at " + std::to_string(baseline.fs) +
                                " Hz but the data is at " + std::to_string(fs) + " Hz");
  Records r{u_est, y_est, u_val, y_val, fs, options.init, options.lags};
  AugmentedModel base;
  base.simulate_baseline = remembered(baseline.simulate);
  if (options.progress) options.progress("simulating the " + baseline.kind + " baseline and fitting its linearisation (OE)");
  const Eigen::VectorXd b_est = base.simulate_baseline(u_est, y_est, options.init);
  const Eigen::VectorXd b_val = base.simulate_baseline(u_val, y_val, options.init);
  // A noise-free output lets high orders fit it exactly (rank-deficient least squares): a dither ~90 dB
  // below it (fixed seeds) keeps the order scan well posed without changing the fit.
  auto dithered = [](const Eigen::VectorXd& y, std::uint64_t seed) -> Eigen::VectorXd {
    const double rms = std::sqrt(y.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, y.size())));
    return y + dsp::gaussian_noise(static_cast<std::size_t>(y.size()), 1e-4 * std::max(rms, 1e-300), seed);
  };
  auto [linear, scan] = best_linear(u_est, dithered(b_est, 1), u_val, dithered(b_val, 2), fs, options);
  base.linear = linear;
  base.reference = linear;
  r.base = &base;
  Diagnosis d;
  d.baseline_kind = baseline.kind;
  d.baseline_info = {{"source", "given"},
                     {"linearisation",
                      {{"method", "oe"}, {"na", linear.tf.na()}, {"nb", linear.tf.nb()}, {"nk", linear.tf.nk},
                       {"J_val_pct_of_the_baseline_output", simulation_j_percent(linear, u_val, b_val, options.init)},
                       {"scan", scan}}}};
  run_rounds(r, options, d);
  return d;
}

bool at_noise_floor(double j_pct, double noise_floor_pct) {
  return noise_floor_pct > 0.0 && j_pct < kNoiseFloorMargin * noise_floor_pct;
}

nlohmann::json diagnosis_to_json(const Diagnosis& d) {
  nlohmann::json findings = nlohmann::json::array();
  for (const auto& f : d.findings)
    findings.push_back({{"effect", to_string(f.effect)},
                        {"explanation", f.explanation},
                        {"evidence", f.evidence},
                        {"parameters", f.parameters},
                        {"J_val_before_pct", f.j_val_before_pct},
                        {"J_val_after_pct", f.j_val_after_pct}});
  nlohmann::json baseline = d.baseline_info;
  baseline["kind"] = d.baseline_kind;
  baseline["J_val_pct"] = d.baseline_j_val_pct;
  baseline["J_est_pct"] = d.baseline_j_est_pct;
  return {{"baseline", baseline},
          {"findings", findings},
          {"J_val_before_pct", d.j_val_before_pct},
          {"J_val_after_pct", d.j_val_after_pct},
          {"noise_floor_pct", d.noise_floor_pct},
          {"at_noise_floor", d.at_noise_floor},
          {"location",
           {{"estimation", location_to_json(d.located_est)},
            {"validation", location_to_json(d.located_val)},
            {"validation_after", location_to_json(d.located_val_after)}}},
          {"rounds", d.rounds},
          {"rule", "an augmentation is kept when N·ln(J_before/J_after) > p·ln(N) on the N validation samples (BIC), p its added parameters; the best such augmentation of each round is applied"}};
}

}  // namespace panelbass::models

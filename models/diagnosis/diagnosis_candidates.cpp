#include "models/diagnosis/diagnosis_candidates.h"

#include <cmath>

#include "models/diagnosis/diagnosis_linear_refits.h"
#include "models/diagnosis/diagnosis_static_nonlinearity.h"

namespace panelbass::models::diagnosis_detail {
namespace {

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

}  // namespace

std::vector<Candidate> candidates(const Records& r, const Fit& current, const ResidualLocation& where,
                                  int oe_iterations, int* tried) {
  std::vector<Candidate> best;
  int fitted = 0;
  // Of the variants of one effect, the one with the best BIC score against `current` is kept.
  const double n_val = static_cast<double>(r.u_val.size() - r.init);
  auto score = [&](const Candidate& c) { return bic_score(current.j_val, c.fit.j_val, c.parameters, n_val); };
  auto offer = [&](Candidate c) {
    ++fitted;
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
    add_term(term_of(Effect::asymmetric_force_factor, p, 0.0), to_string(p), 1, {{"state", to_string(p)}});
    add_term(term_of(Effect::nonlinear_damping, p, 0.0), to_string(p), 1, {{"state", to_string(p)}});
    // Creep: the displacement relaxed over τ (seconds, well below the record's length).
    for (double tau : {0.005, 0.01, 0.02, 0.04, 0.08})
      if (20.0 * tau * r.fs <= static_cast<double>(r.u_est.size()))
        add_term(term_of(Effect::creep, p, 0.0, tau), to_string(p) + ", tau " + fixed(tau * 1000.0, 0) + " ms", 2,
                 {{"state", to_string(p)}, {"time_constant_s", tau}});
  }
  for (StateProxy p : {StateProxy::output, StateProxy::integral, StateProxy::double_integral, StateProxy::input})
    add_term(term_of(Effect::inductance, p, 0.0), to_string(p), 1, {{"state", to_string(p)}});
  // Thermal time constants (seconds) that fit at least four times into the estimation record.
  for (double tau : {0.5, 2.0, 8.0})
    if (4.0 * tau * r.fs <= static_cast<double>(r.u_est.size()))
      add_term(term_of(Effect::thermal_compression, StateProxy::input, 0.0, tau), "tau " + fixed(tau, 1) + " s",
               1, {{"time_constant_s", tau}});
  // Saturation (the drive's static function at its end) and the static nonlinearity (anywhere else in the block
  // structure): diagnosis_static_nonlinearity.cpp places both.
  static_nonlinearity_candidates(r, current, offer);
  linear_refit_candidates(r, current, where, oe_iterations, offer);
  if (tried != nullptr) *tried = fitted;
  return best;
}

Fit every_term_at_once(const Records& r, const Fit& current) {
  std::vector<DiagnosisTerm> terms = current.model.terms;
  auto add = [&](DiagnosisTerm t) {
    if (!has_effect(current.model.terms, t.effect)) terms.push_back(t);
  };
  add(term_of(Effect::dc_offset, StateProxy::output, 0.0));
  for (StateProxy p : {StateProxy::output, StateProxy::integral, StateProxy::double_integral}) {
    if (r.output != OutputQuantity::unknown && p != displacement_proxy(r.output)) continue;
    for (Effect e : {Effect::cubic_stiffness, Effect::asymmetric_stiffness, Effect::hysteresis, Effect::force_factor,
                     Effect::asymmetric_force_factor, Effect::nonlinear_damping})
      add(term_of(e, p, 0.0));
    if (20.0 * 0.02 * r.fs <= static_cast<double>(r.u_est.size())) add(term_of(Effect::creep, p, 0.0, 0.02));
  }
  for (StateProxy p : {StateProxy::output, StateProxy::integral, StateProxy::double_integral, StateProxy::input})
    add(term_of(Effect::inductance, p, 0.0));
  if (4.0 * 2.0 * r.fs <= static_cast<double>(r.u_est.size()))
    add(term_of(Effect::thermal_compression, StateProxy::input, 0.0, 2.0));
  return fit_terms(r, current.model.linear, std::move(terms));
}

}  // namespace panelbass::models::diagnosis_detail

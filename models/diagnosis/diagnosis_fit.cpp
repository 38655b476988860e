#include "models/diagnosis/diagnosis_fit.h"

#include <algorithm>
#include <iomanip>
#include <sstream>

#include "models/linear/oe_estimator.h"
#include "models/optimization/least_squares.h"
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

// Whether any of `terms` reads the output's states: only then does a refinement pass change the regressors.
bool any_reads_the_output(const std::vector<DiagnosisTerm>& terms) {
  return std::ranges::any_of(terms, [](const DiagnosisTerm& t) { return !reads_only_the_input(t); });
}

// `phi` (stacked_regressors' layout) with the columns of the terms that read the output's states recomputed from
// `states`; the others read the input alone, which a refinement pass does not change.
void restack_output_terms(const std::vector<DiagnosisTerm>& terms, const StateSignals& states, const TransferFunction& tf,
                          int lags, Eigen::MatrixXd& phi) {
  int at = 0;
  for (const auto& t : terms) {
    const int c = term_columns(t, lags);
    if (!reads_only_the_input(t)) phi.middleCols(at, c) = term_regressors(t, states, tf, lags);
    at += c;
  }
}

// The augmented output from its base's outputs (raw units; `base` started as judged, `base_rest` from rest).
Eigen::VectorXd augmented_output(const AugmentedModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& base,
                                 const Eigen::VectorXd& base_rest) {
  if (m.terms.empty()) return base;
  const Eigen::VectorXd ys = m.linear.scaling.scale_y(base);
  // The terms' states come from the simulation started at rest, as on the estimation record: a state set
  // from a few noisy outputs can start a slow transient that the integrals behind the states magnify.
  const Eigen::VectorXd ys_rest = m.linear.scaling.scale_y(base_rest);
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
  const bool refine = any_reads_the_output(m.terms);
  for (int pass = 0; refine && pass < kRefinements; ++pass) {
    restack_output_terms(m.terms, state_signals(m.linear.scaling.scale_u(u), ys_rest + phi * c, m.linear.fs, &reference),
                         m.linear.tf, m.lags, phi);
    y_aug = ys + phi * c;
  }
  return m.linear.scaling.unscale_y(y_aug);
}

bool same_linear_part(const LinearModel& a, const LinearModel& b) {
  const Scaling &x = a.scaling, &y = b.scaling;
  // Eigen's == wants equal sizes: the orders first (a refit may change them).
  return a.tf.nk == b.tf.nk && a.tf.a.size() == b.tf.a.size() && a.tf.b.size() == b.tf.b.size() && a.tf.a == b.tf.a &&
         a.tf.b == b.tf.b && a.fs == b.fs && x.u_offset == y.u_offset &&
         x.u_scale == y.u_scale && x.y_offset == y.y_offset && x.y_scale == y.y_scale;
}

}  // namespace

// The augmented model's simulation lives here, beside the fit that runs it for every candidate (the same
// states, the same refinement passes).
Eigen::VectorXd simulate_augmented(const AugmentedModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                   Eigen::Index init) {
  const Eigen::VectorXd base = base_output(m, u, y, init);
  if (m.terms.empty()) return base;
  return augmented_output(m, u, base, base_output(m, u, {}, 0));
}

namespace diagnosis_detail {

bool has_effect(const std::vector<DiagnosisTerm>& terms, Effect e) {
  for (const auto& t : terms)
    if (t.effect == e) return true;
  return false;
}

std::string fixed(double x, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << x;
  return s.str();
}

std::shared_ptr<const BaseOutputs> BaseOutputCache::of(const Records& r, const LinearModel& linear) {
  for (const auto& [kept, outputs] : kept_)
    if (same_linear_part(kept, linear)) return outputs;
  AugmentedModel m = *r.base;
  m.linear = linear;
  auto outputs = std::make_shared<const BaseOutputs>(BaseOutputs{base_output(m, r.u_est, r.y_est, r.init), base_output(m, r.u_est, {}, 0),
                                                                 base_output(m, r.u_val, r.y_val, r.init), base_output(m, r.u_val, {}, 0)});
  if (kept_.size() == kKept) kept_.erase(kept_.begin());
  kept_.emplace_back(linear, outputs);
  return outputs;
}

Fit fit_terms(const Records& r, const LinearModel& linear, std::vector<DiagnosisTerm> terms) {
  Fit f;
  f.model = *r.base;
  f.model.linear = linear;
  f.model.lags = r.lags;
  const std::shared_ptr<const BaseOutputs> kept = r.base_outputs->of(r, linear);
  const BaseOutputs& base = *kept;
  const Eigen::VectorXd y_lin = linear.scaling.scale_y(base.est);
  const Eigen::VectorXd y_rest = linear.scaling.scale_y(base.est_rest);  // states: see augmented_output
  const StateSignals states = state_signals(linear.scaling.scale_u(r.u_est), y_rest, r.fs);
  f.model.state_mean = states.mean;
  f.model.state_rms = states.rms;
  if (!terms.empty()) {
    // Least squares on the regressors of the linear simulation, then refined: the states are re-estimated
    // from the augmented output and the coefficients refitted (kRefinements times; the model's own map).
    const Eigen::VectorXd e = linear.scaling.scale_y(r.y_est) - y_lin;
    Eigen::MatrixXd phi = stacked_regressors(terms, states, linear.tf, r.lags, y_lin.size());
    const Eigen::Index n = phi.rows() - r.init;
    const bool refine = any_reads_the_output(terms);
    for (int pass = 0; pass <= kRefinements; ++pass) {
      const Eigen::VectorXd c = least_squares(phi.bottomRows(n), e.tail(n)).theta;
      int at = 0;
      for (auto& t : terms) {
        const int k = term_columns(t, r.lags);
        t.coefficients = c.segment(at, k);
        at += k;
      }
      if (pass == kRefinements || !refine) break;  // regressors of the input alone: the same again
      const Eigen::VectorXd y_aug = y_rest + phi * c;
      restack_output_terms(terms, state_signals(linear.scaling.scale_u(r.u_est), y_aug, r.fs, &states), linear.tf, r.lags,
                           phi);
    }
  }
  f.model.terms = std::move(terms);
  f.j_est = j_percent(augmented_output(f.model, r.u_est, base.est, base.est_rest), r.y_est, r.init);
  f.j_val = j_percent(augmented_output(f.model, r.u_val, base.val, base.val_rest), r.y_val, r.init);
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

}  // namespace diagnosis_detail
}  // namespace panelbass::models

#include "models/diagnosis/diagnosis_linear_refits.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <vector>

#include "models/linear/linear_identification.h"
#include "models/validation/performance.h"

namespace panelbass::models::diagnosis_detail {
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
  const PoleMode mode = pole_mode(best, fs);
  return {mode.damped_hz, mode.damping_ratio};
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
  if (!y_sim.allFinite()) return std::numeric_limits<double>::infinity();  // no refit recovers a share of it
  return j_ratio_percent((y_sim.tail(m) - y_sim.segment(start - 1, m)).squaredNorm(), energy, "the validation output");
}

/// The share of one_sample_shift_j() a delay refit must recover to be named a dead time.
constexpr double kDelayShareOfShift = 0.25;

}  // namespace

std::string ruled_out_as_extra_mode(const Candidate& c) {
  if ((c.effect != Effect::resonance && c.effect != Effect::antiresonance) ||
      !c.parameters_json.value("retunes_baseline_resonance", false))
    return "";
  return "the pair changes the response at " + fixed(c.parameters_json.value("frequency_hz", 0.0), 1) +
         " Hz, inside the half-power band of the baseline's own resonance at " +
         fixed(c.parameters_json.value("baseline_resonance_hz", 0.0), 1) + " Hz (damping ratio " +
         fixed(c.parameters_json.value("baseline_resonance_damping_ratio", 0.0), 3) +
         "): it retunes that resonance (a changed stiffness or damping, as creep), it adds no mode";
}

void linear_refit_candidates(const Records& r, const Fit& current, const ResidualLocation& where, int oe_iterations,
                             const std::function<void(Candidate)>& offer) {
  // The same structure refitted on the same record: a delay must beat it (what a refit gains by itself, a given
  // baseline from other data, is credited to no effect). A mode's pair is not held to it (on the concealed
  // 450 Hz mode the refit alone gains as much as the pair, docs/diagnosis.md); its J goes with the pair's.
  const LinearModel& linear = current.model.linear;
  const std::vector<DiagnosisTerm>& terms = current.model.terms;
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
               {{"nk_before", tf.nk}, {"nk_after", init.nk}, {"shift_j_pct", j_shift}, {"j_recovered_pct", recovered},
                {"J_val_same_structure_refit_pct", j_same}}});
    }
  }
  // Resonance or antiresonance: a pole pair and a zero pair (cancelling at the start, so the start is the
  // baseline's response) at the residual's spectral peak, then OE moves both. What the pair does decides
  // the name: against the same structure refitted, a change in quadrature with the response (a mode
  // adding its own motion) is a resonance; one opposing the response (the model over-predicting in a
  // narrow band) an antiresonance.
  // Seeded at the residual's spectral peak and, when it lies elsewhere (more than 5 % away), at the FRF error's
  // frequency, where the input explains the residual most: a concealed mode is a linear error below the noise, so
  // the largest residual bin may be a noise bin far from it.
  std::vector<double> seeds;
  if (where.peak_frequency_hz > 0.0) seeds.push_back(where.peak_frequency_hz);
  const double frf_hz = where.frf_error.frequency_hz;
  if (frf_hz > 0.0 && frf_hz < 0.5 * r.fs && (seeds.empty() || std::abs(frf_hz - seeds.front()) > 0.05 * seeds.front()))
    seeds.push_back(frf_hz);
  if (!seeds.empty() && same) {
    // Three starts at each seed, since OE from one tends to stay on one side of the peak: the pairs cancelling,
    // a shallow peak and a shallow dip; the refit that fits the estimation record best is kept.
    Eigen::VectorXd a_full(tf.na() + 1);
    a_full << 1.0, tf.a;
    std::optional<LinearModel> refitted;
    double best_j = std::numeric_limits<double>::infinity(), seeded_at = seeds.front();
    for (double seed_hz : seeds) {
      const double theta = 2.0 * std::numbers::pi * seed_hz / r.fs;
      auto pair_at = [theta](double radius) {
        Eigen::VectorXd pair(3);
        pair << 1.0, -2.0 * radius * std::cos(theta), radius * radius;
        return pair;
      };
      for (const auto& [pole_radius, zero_radius] : {std::pair{0.98, 0.98}, std::pair{0.99, 0.97}, std::pair{0.97, 0.99}}) {
        TransferFunction init = tf;
        init.a = convolve(a_full, pair_at(pole_radius)).tail(tf.na() + 2);
        init.b = convolve(tf.b, pair_at(zero_radius));
        if (auto m = refit_linear(r, linear, init, oe_iterations)) {
          const double j = simulation_j_percent(*m, r.u_est, r.y_est, r.init);
          if (j < best_j) best_j = j, seeded_at = seed_hz, refitted = std::move(m);
        }
      }
    }
    Fit fitted;
    if (refitted) fitted = fit_terms(r, *refitted, terms);
    if (refitted) {
      const PairChange change = pair_change(tf, refitted->tf, seeded_at, r.fs);
      const auto [f, zeta] = pole_pair_near(refitted->tf, change.frequency_hz, r.fs);
      // An extra mode is a pole pair the baseline lacks. A change inside the half-power band of a resonance the
      // baseline already has (|f − f₀| ≤ ζ₀·f₀, ζ₀ light) retunes that resonance — its stiffness or damping, as a
      // creeping suspension does at the main resonance — and is no extra mode.
      const auto [f0, zeta0] = pole_pair_near(tf, change.frequency_hz, r.fs);
      const bool retunes = zeta0 < kLightDamping && std::abs(change.frequency_hz - f0) <= zeta0 * f0;
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
              {"order_after", tf.na() + 2},
              {"seeded_at_hz", seeded_at},
              {"J_val_same_structure_refit_pct", j_same},
              {"baseline_resonance_hz", f0},
              {"baseline_resonance_damping_ratio", zeta0},
              {"retunes_baseline_resonance", retunes}}});
    }
  }
}

}  // namespace panelbass::models::diagnosis_detail

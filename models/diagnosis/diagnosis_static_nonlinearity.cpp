#include "models/diagnosis/diagnosis_static_nonlinearity.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>

namespace panelbass::models::diagnosis_detail {
namespace {

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

// A pole group's natural frequency (Hz; a real pole's corner) and damping ratio.
std::pair<double, double> natural_frequency_and_damping(const Eigen::VectorXcd& group, double fs) {
  const PoleMode mode = pole_mode(group[0], fs);
  return {mode.natural_hz, mode.damping_ratio};
}

// A pole group that is a resonance: a conjugate pair damped lightly (a mode of the mechanics, not a filter's).
bool is_resonance(const Eigen::VectorXcd& group, double fs) {
  return group.size() == 2 && natural_frequency_and_damping(group, fs).second < kLightDamping;
}

// Each pole group of `tf` as its natural frequency (Hz; a real pole's corner) and damping ratio, in
// pole_groups' order.
nlohmann::json pole_groups_json(const TransferFunction& tf, double fs) {
  nlohmann::json out = nlohmann::json::array();
  for (const Eigen::VectorXcd& group : pole_groups(tf)) {
    const auto [frequency, damping] = natural_frequency_and_damping(group, fs);
    out.push_back({{"natural_frequency_hz", frequency}, {"damping_ratio", damping}});
  }
  return out;
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
// drive as sampled (saturation's, placed by the caller), all before it Wiener; between two filters, the front an all-pole
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

// A fitted static function's shape from its coefficients (a static nonlinearity, or a saturation as sampled or
// behind the drive's filter): the static curve, in units of the input of the filter after it, is the linear
// path's slope times z plus Σ_l c_l times each feature; the slope beyond the knee over the slope inside it, per
// side. Below 1: saturating; above: dead-zone-like (the gain rises past the knee).
nlohmann::json static_shape(const DiagnosisTerm& t, const StateSignals& states, int lags) {
  const bool filters = has_block_filters(t);
  const Eigen::VectorXd z = static_nonlinearity_signal(t, states);
  const int width = lags + kTermLead;
  // The baseline G·u is the linear path. As sampled the term passes G itself and z is the normalised drive; at
  // the output (Wiener) front = G; between two filters front·back = A_front(1)·G (block_splits' all-pole front
  // has unit DC gain, its numerator A_front(1)). With front·u = rms_u·front_rms·z plus its mean, the linear
  // path's slope in z is rms_u·front_rms over that factor.
  const double front_rms = filters ? t.front_rms : 1.0;
  const double path_factor = !filters || t.position == Position::output ? 1.0 : t.front.b.sum();
  const double linear_slope = states.rms[3] * front_rms / path_factor;
  if (t.shape == Shape::polynomial) {
    const double c3 = t.coefficients.segment(width, width).sum();
    return {{"shape", "polynomial"}, {"polynomial_order", 3}, {"compressive", c3 * linear_slope < 0.0}};
  }
  // The features are the raw knees minus β·z (orthogonalised): the slope inside is the linear slope − Σ_j C_j·β_j.
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
  const double inside = linear_slope - sums.dot(betas);
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

bool at_drive_end(const TransferFunction& front, const TransferFunction& dynamics, double fs) {
  const std::vector<Eigen::VectorXcd> before = pole_groups(front);
  if (before.empty()) return true;  // nothing before it: the drive as sampled (Hammerstein)
  double lowest_resonance = std::numeric_limits<double>::infinity();
  for (const Eigen::VectorXcd& group : pole_groups(dynamics))
    if (is_resonance(group, fs)) lowest_resonance = std::min(lowest_resonance, natural_frequency_and_damping(group, fs).first);
  if (!std::isfinite(lowest_resonance)) return false;  // no resonance: nothing tells the drive's filter from the rest
  return std::ranges::all_of(before, [&](const Eigen::VectorXcd& group) {
    return !is_resonance(group, fs) && natural_frequency_and_damping(group, fs).first > lowest_resonance;
  });
}

void static_nonlinearity_candidates(const Records& r, const Fit& current, const std::function<void(Candidate)>& offer) {
  const bool want_static = !has_effect(current.model.terms, Effect::static_nonlinearity);
  const bool want_saturation = !has_effect(current.model.terms, Effect::saturation);
  if (!want_static && !want_saturation) return;
  const LinearModel& linear = current.model.linear;
  const StateSignals states = state_signals(linear.scaling.scale_u(r.u_est), linear.scaling.scale_u(r.u_est), r.fs);
  const double n_val = static_cast<double>(r.u_val.size() - r.init);
  // The split, the knee and the sides are choices made from the data: a parameter each. A saturation's knee and
  // sides are one, as they were for the drive as sampled; behind the drive's filter its placement is one more.
  auto fitted = [&](DiagnosisTerm t, int choices) {
    std::vector<DiagnosisTerm> with = current.model.terms;
    with.push_back(t);
    return Candidate{t.effect, "", term_columns(t, r.lags) + choices, fit_terms(r, linear, with), {}};
  };
  auto score = [&](const Candidate& c) { return bic_score(current.j_val, c.fit.j_val, c.parameters, n_val); };
  auto choices_of = [](const DiagnosisTerm& t) {
    if (t.effect == Effect::saturation) return has_block_filters(t) ? 2 : 1;
    return t.shape == Shape::knee ? 3 : 2;
  };
  // Where the static function may sit, each screened with one shape: the drive as sampled and every split whose
  // front is only the drive's filter (at_drive_end) are the amplifier's — saturation, screened alike on both
  // sides with a knee near the peak, where a drive clips; every other split is a static nonlinearity's, screened
  // with each side on its own and a knee at half the peak. The best of each then gets every shape of its own.
  std::optional<Candidate> best_static, best_drive;
  DiagnosisTerm best_static_term, best_drive_term;
  auto screen = [&](DiagnosisTerm t, double knee_fraction) {
    t.threshold = knee_fraction * static_nonlinearity_signal(t, states).cwiseAbs().maxCoeff();
    Candidate c = fitted(t, choices_of(t));
    std::optional<Candidate>& best = t.effect == Effect::saturation ? best_drive : best_static;
    if (!best || score(c) > score(*best)) best = std::move(c), (t.effect == Effect::saturation ? best_drive_term : best_static_term) = t;
  };
  constexpr double kDriveScreenKnee = 0.8, kStaticScreenKnee = 0.5;
  if (want_saturation) {
    DiagnosisTerm t;
    t.effect = Effect::saturation;
    t.proxy = StateProxy::input;
    screen(t, kDriveScreenKnee);
  }
  for (const auto& [front, back] : block_splits(linear.tf)) {
    const bool drive_end = at_drive_end(front, linear.tf, r.fs);
    if (drive_end ? !want_saturation : !want_static) continue;
    DiagnosisTerm t;
    t.effect = drive_end ? Effect::saturation : Effect::static_nonlinearity;
    t.proxy = StateProxy::input;
    t.position = drive_end ? Position::input
                 : back.a.size() == 0 && back.nk == 0 && back.b.size() == 1 ? Position::output
                                                                            : Position::between;
    t.front = front;
    t.back = back;
    const Eigen::VectorXd w = filter_through(front, states.input);
    t.front_rms = std::sqrt(w.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, w.size())));
    if (!(t.front_rms > 0.0) || !std::isfinite(t.front_rms)) continue;
    t.one_sided = !drive_end;
    screen(t, drive_end ? kDriveScreenKnee : kStaticScreenKnee);
  }
  // The kept term's placement in the report: the pole groups before and after it.
  auto placement = [&](const DiagnosisTerm& t, nlohmann::json& p) {
    p["front_order"] = t.front.na();
    p["back_order"] = t.back.na();
    p["front_poles"] = pole_groups_json(t.front, r.fs);
    p["back_poles"] = pole_groups_json(t.back, r.fs);
  };
  if (best_drive) {
    // Saturation of the drive, both sides alike (an amplifier) or each on its own (a diode), where the screen put
    // it; knees at fractions of the peak of the signal it acts on, on the estimation record.
    const double peak = static_nonlinearity_signal(best_drive_term, states).cwiseAbs().maxCoeff();
    const bool behind_filter = has_block_filters(best_drive_term);
    for (bool one_sided : {false, true})
      for (double fraction : {0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.93, 0.95, 0.97, 0.99}) {
        DiagnosisTerm t = best_drive_term;
        t.one_sided = one_sided;
        t.threshold = fraction * peak;
        Candidate c = fitted(t, choices_of(t));
        c.variant = (behind_filter ? "behind the drive's filter (" + std::to_string(t.front.na()) +
                                         (t.front.na() == 1 ? " pole), " : " poles), ")
                                   : std::string()) +
                    (one_sided ? "each side" : "both sides") + ", knee " + fixed(fraction, 2);
        c.parameters_json = {{"knee_fraction_of_peak", fraction}, {"one_sided", one_sided}, {"position", "input"},
                             {"structure", behind_filter ? "Hammerstein behind the drive's filter" : "Hammerstein"}};
        const nlohmann::json shape = static_shape(c.fit.model.terms.back(), states, r.lags);
        for (auto it = shape.begin(); it != shape.end(); ++it) c.parameters_json[it.key()] = it.value();
        if (behind_filter) placement(t, c.parameters_json);
        offer(std::move(c));
      }
  }
  if (!best_static) return;
  const double peak = static_nonlinearity_signal(best_static_term, states).cwiseAbs().maxCoeff();
  std::vector<DiagnosisTerm> shapes;
  for (bool one_sided : {false, true})
    for (double fraction : {0.2, 0.35, 0.5, 0.65, 0.8}) {
      DiagnosisTerm t = best_static_term;
      t.one_sided = one_sided;
      t.threshold = fraction * peak;
      shapes.push_back(t);
    }
  DiagnosisTerm poly = best_static_term;
  poly.shape = Shape::polynomial;
  shapes.push_back(poly);
  for (const auto& t : shapes) {
    Candidate c = fitted(t, choices_of(t));
    const DiagnosisTerm& kept = c.fit.model.terms.back();
    const std::string where = t.position == Position::output ? "output" : "between";
    c.variant = std::string(where == "output" ? "Wiener" : "Wiener–Hammerstein") + ", " +
                (t.shape == Shape::polynomial ? std::string("polynomial")
                                              : std::string(t.one_sided ? "each side" : "both sides") + ", knee " +
                                                    fixed(t.threshold / peak, 2));
    c.parameters_json = static_shape(kept, states, r.lags);
    c.parameters_json["position"] = where;
    c.parameters_json["structure"] = where == "output" ? "Wiener" : "Wiener–Hammerstein";
    placement(t, c.parameters_json);
    if (t.shape == Shape::knee) {
      c.parameters_json["knee_fraction_of_peak"] = t.threshold / peak;
      c.parameters_json["one_sided"] = t.one_sided;
    }
    offer(std::move(c));
  }
}

}  // namespace panelbass::models::diagnosis_detail

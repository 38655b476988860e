#include "models/state_space_nn/ss_wiener_hammerstein.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "models/linear/oe_estimator.h"
#include "models/linear/state_space.h"
#include "models/optimization/levenberg_marquardt.h"
#include "models/state_space_nn/ss_training.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

constexpr Eigen::Index kSearchSamples = 20000;  // samples of each record the split search reads
constexpr double kTail = 0.001;                 // the centres span v's quantiles kTail … 1 − kTail
constexpr int kTrialSteps = 20;                 // refinement steps of each candidate split before one is kept

using Roots = std::vector<std::complex<double>>;

/// Real roots alone, complex ones with their conjugate: the factors a real filter can take whole.
std::vector<Roots> root_groups(const Eigen::VectorXcd& roots) {
  std::vector<Roots> groups;
  for (const auto& r : roots) {
    const bool real = std::abs(r.imag()) <= 1e-9 * (1.0 + std::abs(r));
    if (real) {
      groups.push_back({{r.real(), 0.0}});
    } else if (r.imag() > 0.0) {
      groups.push_back({r, std::conj(r)});
    }
  }
  return groups;
}

/// The roots of the groups chosen by `mask` (bit g: group g) or, with `chosen` false, of the others.
Eigen::VectorXcd pick(const std::vector<Roots>& groups, unsigned mask, bool chosen) {
  Roots out;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    if (((mask >> g) & 1U) == static_cast<unsigned>(chosen)) out.insert(out.end(), groups[g].begin(), groups[g].end());
  }
  return Eigen::Map<const Eigen::VectorXcd>(out.data(), static_cast<Eigen::Index>(out.size()));
}

/// Π (1 − r·q⁻¹) over `poles` and `zeros` as a transfer function with input delay `delay` and gain `gain`.
TransferFunction factor_filter(const Eigen::VectorXcd& poles, const Eigen::VectorXcd& zeros, int delay, double gain) {
  TransferFunction tf;
  tf.a = polynomial_from_roots(poles).tail(poles.size());
  tf.b = gain * polynomial_from_roots(zeros);
  tf.nk = delay;
  return tf;
}

/// The static nonlinearity's basis at v: [1, v, tanh(w₁·(v − c₁)), …].
Eigen::MatrixXd basis(const Eigen::VectorXd& v, const Eigen::VectorXd& centres, const Eigen::VectorXd& slopes) {
  Eigen::MatrixXd phi(v.size(), centres.size() + 2);
  phi.col(0).setOnes();
  phi.col(1) = v;
  for (Eigen::Index i = 0; i < centres.size(); ++i) phi.col(i + 2) = (slopes(i) * (v.array() - centres(i))).tanh();
  return phi;
}

/// Each column of `phi` through `filter` from rest.
Eigen::MatrixXd filter_columns(const StateSpace& filter, const Eigen::MatrixXd& phi) {
  Eigen::MatrixXd out(phi.rows(), phi.cols());
  for (Eigen::Index j = 0; j < phi.cols(); ++j) out.col(j) = simulate(filter, phi.col(j));
  return out;
}

/// One split's fit: the blocks (the front filter scaled so v has unit RMS) and its J.
struct SplitFit : WhBlocks {
  double j_pct = std::numeric_limits<double>::infinity();
};

SplitFit fit_split(TransferFunction front, const TransferFunction& back, int hidden, const Eigen::VectorXd& us,
                   const Eigen::VectorXd& ys, const Eigen::VectorXd& us_sel, const Eigen::VectorXd& ys_sel,
                   Eigen::Index skip) {
  SplitFit fit;
  const Eigen::VectorXd v_raw = simulate(realize(front), us);
  const double rms = std::sqrt(v_raw.squaredNorm() / static_cast<double>(v_raw.size()));
  if (!(rms > 1e-12) || !std::isfinite(rms)) return fit;
  front.b /= rms;
  const Eigen::VectorXd v = v_raw / rms;
  Eigen::VectorXd sorted = v;
  std::sort(sorted.begin(), sorted.end());
  // The centres evenly spaced over v's range (its extreme quantiles), each node's slope one over their spacing:
  // a saturation sits where v is largest, where quantile-spaced centres would be sparsest.
  const auto quantile = [&](double q) { return sorted(static_cast<Eigen::Index>(q * static_cast<double>(sorted.size() - 1))); };
  const double low = quantile(kTail), high = quantile(1.0 - kTail), spacing = (high - low) / hidden;
  fit.centres = Eigen::VectorXd::LinSpaced(hidden, low + 0.5 * spacing, high - 0.5 * spacing);
  fit.slopes = Eigen::VectorXd::Constant(hidden, 1.0 / spacing);
  const StateSpace back_ss = realize(back);
  const Eigen::MatrixXd M = filter_columns(back_ss, basis(v, fit.centres, fit.slopes)).bottomRows(v.size() - skip);
  // Ridge least squares on columns of unit norm (the tanh nodes overlap: their columns are nearly dependent).
  const Eigen::VectorXd norms = M.colwise().norm().transpose().cwiseMax(1e-300);
  const Eigen::MatrixXd Mn = M * norms.cwiseInverse().asDiagonal();
  Eigen::MatrixXd gram = Mn.transpose() * Mn;
  gram.diagonal().array() += 1e-9 * gram.diagonal().mean();
  fit.coefficients = gram.ldlt().solve(Mn.transpose() * ys.tail(v.size() - skip)).cwiseQuotient(norms);
  if (!fit.coefficients.allFinite()) return fit;
  const Eigen::VectorXd v_sel = simulate(realize(front), us_sel);
  const Eigen::VectorXd y_hat = filter_columns(back_ss, basis(v_sel, fit.centres, fit.slopes)) * fit.coefficients;
  fit.j_pct = j_percent(y_hat, ys_sel, skip);
  fit.front = std::move(front);
  fit.back = back;
  return fit;
}

/// The fit of θ, the shapes those of `like`.
SplitFit unpack(const Eigen::VectorXd& theta, const SplitFit& like) {
  SplitFit f = like;
  static_cast<WhBlocks&>(f) = like.unpack(theta);
  return f;
}

/// The block model's output from rest: y = G2·g(G1·u); `v` and `w` receive G1·u and g(v).
Eigen::VectorXd block_signals(const WhBlocks& f, const Eigen::VectorXd& us, Eigen::VectorXd* v_out,
                              Eigen::VectorXd* w_out) {
  const Eigen::VectorXd v = simulate(realize(f.front), us);
  const Eigen::VectorXd w = basis(v, f.centres, f.slopes) * f.coefficients;
  if (v_out != nullptr) *v_out = v;
  if (w_out != nullptr) *w_out = w;
  return simulate(realize(f.back), w);
}

}  // namespace

Eigen::VectorXd WhBlocks::pack() const {
  Eigen::VectorXd theta(front.na() + front.nb() + back.na() + back.nb() + coefficients.size() + centres.size() +
                        slopes.size());
  theta << front.a, front.b, back.a, back.b, coefficients, centres, slopes;
  return theta;
}

WhBlocks WhBlocks::unpack(const Eigen::VectorXd& theta) const {
  WhBlocks f = *this;
  if (theta.size() != pack().size()) {
    throw std::invalid_argument("WhBlocks::unpack: " + std::to_string(theta.size()) + " parameters, " +
                                std::to_string(pack().size()) + " expected");
  }
  Eigen::Index at = 0;
  for (Eigen::VectorXd* part : {&f.front.a, &f.front.b, &f.back.a, &f.back.b, &f.coefficients, &f.centres, &f.slopes}) {
    *part = theta.segment(at, part->size());
    at += part->size();
  }
  return f;
}

Eigen::VectorXd wh_block_output(const WhBlocks& blocks, const Eigen::VectorXd& u) {
  return block_signals(blocks, u, nullptr, nullptr);
}

// The back filter's columns by its OE sensitivities to w; the nonlinearity's and the front filter's through
// G2, the front's times g'(v) (the chain rule sample by sample).
Eigen::MatrixXd wh_block_jacobian(const WhBlocks& f, const Eigen::VectorXd& us) {
  Eigen::VectorXd v, w;
  block_signals(f, us, &v, &w);
  const Eigen::Index N = us.size(), H = f.centres.size();
  const Eigen::Index n_front = f.front.na() + f.front.nb(), n_back = f.back.na() + f.back.nb();
  Eigen::MatrixXd J(N, n_front + n_back + 3 * H + 2);
  const StateSpace g2 = realize(f.back);
  J.middleCols(n_front, n_back) = oe_jacobian(w, f.back);
  // g'(v) = p₁ + Σ pᵢ·wᵢ·sech²(wᵢ·(v − cᵢ)); the nodes' own columns before G2: ∂g/∂p, ∂g/∂c, ∂g/∂w
  Eigen::ArrayXd slope_of_g = Eigen::ArrayXd::Constant(N, f.coefficients(1));
  Eigen::MatrixXd inner(N, 3 * H + 2);
  inner.leftCols(H + 2) = basis(v, f.centres, f.slopes);
  for (Eigen::Index i = 0; i < H; ++i) {
    const Eigen::ArrayXd offset = v.array() - f.centres(i);
    const Eigen::ArrayXd sech2 = 1.0 - (f.slopes(i) * offset).tanh().square();
    const double p = f.coefficients(i + 2);
    slope_of_g += p * f.slopes(i) * sech2;
    inner.col(H + 2 + i) = -p * f.slopes(i) * sech2;
    inner.col(2 * H + 2 + i) = p * offset * sech2;
  }
  for (Eigen::Index j = 0; j < inner.cols(); ++j) J.col(n_front + n_back + j) = simulate(g2, inner.col(j));
  const Eigen::MatrixXd dv = oe_jacobian(us, f.front);
  for (Eigen::Index j = 0; j < n_front; ++j) J.col(j) = simulate(g2, (dv.col(j).array() * slope_of_g).matrix());
  return J;
}

namespace {

/// Levenberg–Marquardt on the block model's simulation error (from rest, rows from `skip` on) over the
/// estimation data, keeping the iterate of the lowest J on the selection data among those `bounded` accepts
/// (asked only of an iterate that would replace the kept one; while the start is not bounded, any finite J
/// replaces it); `iterations` steps at most.
SplitFit refine_split(const SplitFit& start, const Eigen::VectorXd& us, const Eigen::VectorXd& ys,
                      const Eigen::VectorXd& us_sel, const Eigen::VectorXd& ys_sel, Eigen::Index skip, int iterations,
                      int& steps, const std::function<bool(const SplitFit&)>& bounded) {
  const Eigen::Index rows = us.size() - skip;
  auto loss_of = [&](const SplitFit& f) {
    if (!f.front.is_stable() || !f.back.is_stable()) return std::numeric_limits<double>::infinity();
    const Eigen::VectorXd e = wh_block_output(f, us).tail(rows) - ys.tail(rows);
    return e.allFinite() ? 0.5 * e.squaredNorm() : std::numeric_limits<double>::infinity();
  };
  SplitFit best = start, current = start;
  bool best_bounded = bounded(start);
  Eigen::VectorXd theta = start.pack();
  LevenbergMarquardt lm({.damping = LmDamping::relative_to_mean}, theta.size());
  double V = loss_of(current);
  for (int it = 0; it < iterations && std::isfinite(V); ++it) {
    const Eigen::MatrixXd J = wh_block_jacobian(current, us).bottomRows(rows);
    const Eigen::VectorXd e = wh_block_output(current, us).tail(rows) - ys.tail(rows);
    const Eigen::MatrixXd H = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * e;
    const LmStep step = lm.step(H, g, V, theta, [&](const Eigen::VectorXd& candidate) { return loss_of(unpack(candidate, start)); });
    if (!step.accepted || V - step.loss <= 1e-12 * V) break;
    V = step.loss;
    steps = it + 1;
    current = unpack(theta, start);
    current.j_pct = j_percent(wh_block_output(current, us_sel), ys_sel, skip);
    if (std::isfinite(current.j_pct) && (current.j_pct < best.j_pct || !best_bounded) && bounded(current)) {
      best = current;
      best_bounded = true;
    }
  }
  return best;
}

/// The block model of `fit` written as an SsModel of structure `s` (hidden = the fit's nodes).
SsModel block_model(const SplitFit& fit, SsStructure s, const Scaling& scaling, double fs, std::uint64_t seed) {
  const StateSpace g1 = realize(fit.front), g2 = realize(fit.back);
  const Eigen::Index n1 = g1.order(), n2 = g2.order(), n = n1 + n2;
  const Eigen::VectorXd& p = fit.coefficients;
  StateSpace linear;
  linear.A = Eigen::MatrixXd::Zero(n, n);
  linear.A.topLeftCorner(n1, n1) = g1.A;
  linear.A.bottomLeftCorner(n2, n1) = p(1) * g2.B * g1.C;
  linear.A.bottomRightCorner(n2, n2) = g2.A;
  linear.B.resize(n);
  linear.B << g1.B, p(1) * g1.D * g2.B;
  linear.C.resize(n);
  linear.C << p(1) * g2.D * g1.C, g2.C;
  linear.D = p(1) * g2.D * g1.D;
  SsModel m = ss_model_from_linear(linear, s, Eigen::VectorXd::Ones(n), scaling, fs, seed);
  auto parts = ss_parts(m.structure, m.theta.data());
  parts.W1.setZero();
  parts.W2.setZero();
  for (Eigen::Index i = 0; i < s.hidden; ++i) {
    // tanh(w·(v − cᵢ)) with v = C1·x1 + D1·u
    parts.W1.row(i).head(n1) = fit.slopes(i) * g1.C;
    parts.W1(i, n) = fit.slopes(i) * g1.D;
    parts.b1(i, 0) = -fit.slopes(i) * fit.centres(i);
    parts.W2.col(i).segment(n1, n2) = p(i + 2) * g2.B;
    parts.W2(n, i) = p(i + 2) * g2.D;
  }
  parts.b2.col(0).setZero();
  parts.b2.col(0).segment(n1, n2) = p(0) * g2.B;
  parts.b2(n, 0) = p(0) * g2.D;
  return m;
}

}  // namespace

SsWienerHammerstein ss_wiener_hammerstein_start(const LinearModel& bla, SsStructure structure, const Eigen::VectorXd& u,
                                                const Eigen::VectorXd& y, const Eigen::VectorXd& u_val,
                                                const Eigen::VectorXd& y_val, int iterations, std::uint64_t seed,
                                                int candidates) {
  if (candidates < 1) throw std::invalid_argument("ss_wiener_hammerstein_start: candidates must be at least 1");
  if (structure.hidden < 1) throw std::invalid_argument("ss_wiener_hammerstein_start: the nonlinearity needs hidden >= 1 tanh nodes");
  if (structure.activation != SsActivation::tanh || !structure.hidden_input) {
    throw std::invalid_argument("ss_wiener_hammerstein_start: the block model's nodes are tanh nodes reading the input");
  }
  if (bla.tf.na() < 1) throw std::invalid_argument("ss_wiener_hammerstein_start: the linear model has no pole to split");
  if (u.size() != y.size() || u_val.size() != y_val.size()) {
    throw std::invalid_argument("ss_wiener_hammerstein_start: input and output lengths differ");
  }
  if (u.size() <= 3 * structure.lags) {
    throw std::invalid_argument("ss_wiener_hammerstein_start: " + std::to_string(u.size()) + " samples are too few for " +
                                std::to_string(structure.lags) + " encoder lags");
  }
  const bool has_val = u_val.size() != 0;
  const Eigen::VectorXd us_all = bla.scaling.scale_u(u), ys_all = bla.scaling.scale_y(y);
  const Eigen::VectorXd us_sel_all = has_val ? bla.scaling.scale_u(u_val) : us_all;
  const Eigen::VectorXd ys_sel_all = has_val ? bla.scaling.scale_y(y_val) : ys_all;
  const Eigen::VectorXd us = us_all.head(std::min(kSearchSamples, us_all.size()));
  const Eigen::VectorXd ys = ys_all.head(us.size());
  const Eigen::VectorXd us_sel = us_sel_all.head(std::min(kSearchSamples, us_sel_all.size()));
  const Eigen::VectorXd ys_sel = ys_sel_all.head(us_sel.size());
  const Eigen::Index skip = std::min<Eigen::Index>(100, us_sel.size() / 10);

  // The numerator's leading zero coefficients are more delay; its first non-zero one is the gain.
  int lead = 0;
  while (lead < bla.tf.nb() && bla.tf.b(lead) == 0.0) ++lead;
  if (lead == bla.tf.nb()) throw std::invalid_argument("ss_wiener_hammerstein_start: the linear model's numerator is zero");
  const int delay = bla.tf.nk + lead;
  const std::vector<Roots> poles = root_groups(bla.tf.poles()), zeros = root_groups(bla.tf.zeros());
  if (poles.size() + zeros.size() > 20) throw std::invalid_argument("ss_wiener_hammerstein_start: too many poles and zeros to split");
  const int order = realize(bla.tf).order();

  SsWienerHammerstein out;
  out.linear_j_pct = j_percent(simulate(realize(bla.tf), us_sel), ys_sel, skip);
  std::vector<SplitFit> fits;  // every split's fit, the lowest J first after the search
  for (unsigned pm = 0; pm < (1U << poles.size()); ++pm) {
    for (unsigned zm = 0; zm < (1U << zeros.size()); ++zm) {
      const TransferFunction front = factor_filter(pick(poles, pm, true), pick(zeros, zm, true), delay, 1.0);
      const TransferFunction back = factor_filter(pick(poles, pm, false), pick(zeros, zm, false), 0, 1.0);
      // Only the splits that keep the linear model's number of states.
      const int n1 = std::max(front.na(), front.nk + front.nb() - 1), n2 = std::max(back.na(), back.nb() - 1);
      if (n1 + n2 > order) continue;
      ++out.splits;
      SplitFit fit = fit_split(front, back, structure.hidden, us, ys, us_sel, ys_sel, skip);
      if (std::isfinite(fit.j_pct)) fits.push_back(std::move(fit));
    }
  }
  if (fits.empty()) throw std::invalid_argument("ss_wiener_hammerstein_start: no split could be fitted");
  std::stable_sort(fits.begin(), fits.end(), [](const SplitFit& a, const SplitFit& b) { return a.j_pct < b.j_pct; });
  out.candidates = iterations > 0 ? std::min<int>(candidates, static_cast<int>(fits.size())) : 1;
  // A split is a candidate only when its model's free run is bounded (the loader's test); the encoder,
  // fitted last, is left out (zero).
  const std::function<bool(const SplitFit&)> bounded = [&](const SplitFit& fit) {
    return !ss_free_run_runaway(block_model(fit, structure, bla.scaling, bla.fs, seed));
  };
  const auto first_bounded = std::find_if(fits.begin(), fits.end(), bounded);
  SplitFit best = first_bounded != fits.end() ? *first_bounded : fits.front();
  double search_j = best.j_pct;
  if (iterations > 0) {
    // Each candidate split's J on the whole selection record from rest, then (with more than one) a short
    // joint refinement of each: the one of the lowest J after it is the one refined on.
    const int trial_steps = out.candidates > 1 ? std::min(iterations, kTrialSteps) : 0;
    best.j_pct = std::numeric_limits<double>::infinity();
    for (int c = 0; c < out.candidates; ++c) {
      SplitFit fit = fits[static_cast<std::size_t>(c)];
      const double fit_search_j = fit.j_pct;
      fit.j_pct = j_percent(wh_block_output(fit, us_sel_all), ys_sel_all, skip);
      int steps = 0;
      if (trial_steps > 0) fit = refine_split(fit, us_all, ys_all, us_sel_all, ys_sel_all, skip, trial_steps, steps, bounded);
      if (fit.j_pct < best.j_pct && bounded(fit)) {
        best = std::move(fit);
        search_j = fit_search_j;
        out.iterations = steps;
      }
    }
    // The kept split refined jointly on the whole records.
    int steps = 0;
    best = refine_split(best, us_all, ys_all, us_sel_all, ys_sel_all, skip, iterations - out.iterations, steps, bounded);
    out.iterations += steps;
  }
  out.search_j_pct = search_j;
  out.front_poles = best.front.na();
  out.front_zeros = static_cast<int>(best.front.nb()) - 1;
  out.j_pct = best.j_pct;
  out.model = block_model(best, structure, bla.scaling, bla.fs, seed);
  out.front_states = realize(best.front).order();
  // The block model's states along the estimation data, from rest: the encoder's least-squares target.
  SsModel& m = out.model;
  const auto parts = ss_parts(m.structure, static_cast<const double*>(m.theta.data()));
  const Eigen::Index n = m.structure.states;
  Eigen::MatrixXd states(n, us_all.size());
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n), next(n);
  Eigen::RowVectorXd input(1), output(1);
  SsStepWork work;
  for (Eigen::Index k = 0; k < us_all.size(); ++k) {
    states.col(k) = x;
    input(0) = us_all(k);
    ss_step(parts, x, input, work, output, next);
    x.swap(next);
  }
  ss_fit_encoder(m, us_all, ys_all, states);
  return out;
}

}  // namespace panelbass::models

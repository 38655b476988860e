#include "models/state_space_nn/ss_wiener_hammerstein.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "models/linear/state_space.h"
#include "models/state_space_nn/ss_training.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

constexpr Eigen::Index kSearchSamples = 20000;  // samples of each record the split search reads
constexpr double kTail = 0.001;                 // the centres span v's quantiles kTail … 1 − kTail

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

/// The static nonlinearity's basis at v: [1, v, tanh(w·(v − c₁)), …].
Eigen::MatrixXd basis(const Eigen::VectorXd& v, const Eigen::VectorXd& centres, double slope) {
  Eigen::MatrixXd phi(v.size(), centres.size() + 2);
  phi.col(0).setOnes();
  phi.col(1) = v;
  for (Eigen::Index i = 0; i < centres.size(); ++i) phi.col(i + 2) = (slope * (v.array() - centres(i))).tanh();
  return phi;
}

/// Each column of `phi` through `filter` from rest.
Eigen::MatrixXd filter_columns(const StateSpace& filter, const Eigen::MatrixXd& phi) {
  Eigen::MatrixXd out(phi.rows(), phi.cols());
  for (Eigen::Index j = 0; j < phi.cols(); ++j) out.col(j) = simulate(filter, phi.col(j));
  return out;
}

/// One split's fit: the front filter (scaled so v has unit RMS), the centres, g's coefficients, its J.
struct SplitFit {
  TransferFunction front, back;
  Eigen::VectorXd centres, coefficients;
  double slope = 1.0;  ///< w
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
  fit.slope = 1.0 / spacing;
  const StateSpace back_ss = realize(back);
  const Eigen::MatrixXd M = filter_columns(back_ss, basis(v, fit.centres, fit.slope)).bottomRows(v.size() - skip);
  // Ridge least squares on columns of unit norm (the tanh nodes overlap: their columns are nearly dependent).
  const Eigen::VectorXd norms = M.colwise().norm().transpose().cwiseMax(1e-300);
  const Eigen::MatrixXd Mn = M * norms.cwiseInverse().asDiagonal();
  Eigen::MatrixXd gram = Mn.transpose() * Mn;
  gram.diagonal().array() += 1e-9 * gram.diagonal().mean();
  fit.coefficients = gram.ldlt().solve(Mn.transpose() * ys.tail(v.size() - skip)).cwiseQuotient(norms);
  if (!fit.coefficients.allFinite()) return fit;
  const Eigen::VectorXd v_sel = simulate(realize(front), us_sel);
  const Eigen::VectorXd y_hat = filter_columns(back_ss, basis(v_sel, fit.centres, fit.slope)) * fit.coefficients;
  fit.j_pct = j_percent(y_hat, ys_sel, skip);
  fit.front = std::move(front);
  fit.back = back;
  return fit;
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
    parts.W1.row(i).head(n1) = fit.slope * g1.C;
    parts.W1(i, n) = fit.slope * g1.D;
    parts.b1(i, 0) = -fit.slope * fit.centres(i);
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
                                                const Eigen::VectorXd& y_val, std::uint64_t seed) {
  if (structure.hidden < 1) throw std::invalid_argument("ss_wiener_hammerstein_start: the nonlinearity needs hidden >= 1 tanh nodes");
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
  SplitFit best;
  for (unsigned pm = 0; pm < (1U << poles.size()); ++pm) {
    for (unsigned zm = 0; zm < (1U << zeros.size()); ++zm) {
      const TransferFunction front = factor_filter(pick(poles, pm, true), pick(zeros, zm, true), delay, 1.0);
      const TransferFunction back = factor_filter(pick(poles, pm, false), pick(zeros, zm, false), 0, 1.0);
      // Only the splits that keep the linear model's number of states.
      const int n1 = std::max(front.na(), front.nk + front.nb() - 1), n2 = std::max(back.na(), back.nb() - 1);
      if (n1 + n2 > order) continue;
      ++out.splits;
      SplitFit fit = fit_split(front, back, structure.hidden, us, ys, us_sel, ys_sel, skip);
      if (fit.j_pct < best.j_pct) {
        best = std::move(fit);
        out.front_poles = front.na();
        out.front_zeros = front.nb() - 1;
      }
    }
  }
  if (!std::isfinite(best.j_pct)) throw std::invalid_argument("ss_wiener_hammerstein_start: no split could be fitted");
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

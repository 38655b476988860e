// Multiple shooting for NARX training. Choices beyond the header:
// - The windows start at the trainer's skip (≥ init), so the stacked loss covers the samples the single-shooting
//   loss covers; every window's history is free, the first one's too (it has no continuity to keep).
// - Each window's sensitivities ψ(k) = d ŷ(k)/d[θ; h_w] run the [5L] recursion with the history as its start:
//   dŷ(s_w−1−i)/dθ = 0, dŷ(s_w−1−i)/dh_w = e_i. The matrix of one window (over [θ; h_{w−1}; h_w]: its samples
//   and the continuity rows that tie h_w to window w−1's last outputs) is accumulated in blocks and added into
//   the stack's, whose other entries are 0 (a window sees only its own history and its predecessor's).
#include "models/narx/narx_multiple_shooting.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "models/narx/narx_history.h"

namespace panelbass::models {
namespace {

/// Residual gradients gathered per block before one H += B·Bᵀ (as narx_gradients' blocks: under 96 kB).
Eigen::Index shooting_block_columns(Eigen::Index rows) {
  constexpr Eigen::Index kBlockBytes = 96 * 1024;
  return std::clamp<Eigen::Index>(kBlockBytes / (static_cast<Eigen::Index>(sizeof(double)) * rows), 4, 64);
}

/// H[at_r.., at_c..] += L[from_r.., from_c..] (rows × cols), and the mirrored block when off the diagonal.
void add_block(Eigen::MatrixXd& H, const Eigen::MatrixXd& L, Eigen::Index at_r, Eigen::Index at_c, Eigen::Index from_r,
               Eigen::Index from_c, Eigen::Index rows, Eigen::Index cols) {
  H.block(at_r, at_c, rows, cols) += L.block(from_r, from_c, rows, cols);
  if (at_r != at_c) H.block(at_c, at_r, cols, rows) += L.block(from_r, from_c, rows, cols).transpose();
}

}  // namespace

void require_multiple_shooting_options(const MultipleShootingOptions& o, int na) {
  if (o.window < std::max<Eigen::Index>(na, 1)) {
    throw std::invalid_argument("NARX training: multiple-shooting window must be ≥ max(na, 1) = " +
                                std::to_string(std::max(na, 1)) + " samples, got " + std::to_string(o.window));
  }
  if (!(o.penalty > 0.0) || !std::isfinite(o.penalty)) {
    throw std::invalid_argument("NARX training: multiple-shooting penalty must be a finite number > 0, got " +
                                std::to_string(o.penalty));
  }
  if (!(o.penalty_growth >= 1.0) || !std::isfinite(o.penalty_growth)) {
    throw std::invalid_argument("NARX training: multiple-shooting penalty growth must be a finite number ≥ 1, got " +
                                std::to_string(o.penalty_growth));
  }
  if (!(o.penalty_max >= o.penalty) || !std::isfinite(o.penalty_max)) {
    throw std::invalid_argument("NARX training: multiple-shooting penalty maximum must be finite and ≥ the penalty " +
                                std::to_string(o.penalty) + ", got " + std::to_string(o.penalty_max));
  }
}

MultipleShooting::MultipleShooting(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                   Eigen::Index start, const MultipleShootingOptions& options,
                                   const Eigen::VectorXd& weights)
    : options_(options),
      na_(model.structure.na),
      nb_(model.structure.nb),
      nk_(model.structure.nk),
      P_(model.net.parameter_count()),
      u_(u),
      y_(y),
      weights_(weights),
      penalty_(options.penalty) {
  require_multiple_shooting_options(options, na_);
  const Eigen::Index N = u.size();
  if (start < 0 || N - start < options.window) {
    throw std::invalid_argument("NARX training: multiple shooting needs at least one window of " +
                                std::to_string(options.window) + " samples after sample " + std::to_string(start) +
                                ", the record has " + std::to_string(N));
  }
  const Eigen::Index W = (N - start) / options.window;
  for (Eigen::Index w = 0; w < W; ++w) starts_.push_back(start + w * options.window);
  starts_.push_back(N);  // the last window takes the remainder
  weight_total_ = weights.size() == 0 ? static_cast<double>(N - start) : weights.tail(N - start).sum();
  // The histories start at the measured outputs: each window starts where the record is.
  histories_.resize(na_ * W);
  for (Eigen::Index w = 0; w < W; ++w) {
    for (int i = 0; i < na_; ++i) {
      const Eigen::Index k = starts_[static_cast<std::size_t>(w)] - 1 - i;
      histories_[w * na_ + i] = k >= 0 ? y[k] : 0.0;
    }
  }
  const Eigen::Index longest = N - starts_[static_cast<std::size_t>(W - 1)];
  const Eigen::Index Q = P_ + 2 * na_;
  ws_ = model.net.workspace();
  x_.resize(model.net.inputs());
  dtheta_.resize(P_);
  dx_.resize(model.net.inputs());
  sim_.resize(na_ + longest);
  ring_.resize(P_ + na_, na_);
  tail_.resize(P_ + na_, na_);
  tail_y_.resize(na_);
  block_.resize(Q, shooting_block_columns(Q));
  local_h_.resize(Q, Q);
  local_g_.resize(Q);
  row_.resize(Q);
}

double MultipleShooting::window_sweep(const NarxModel& model, const Eigen::Ref<const Eigen::VectorXd>& histories,
                                      Eigen::Index w, bool sensitivities) {
  const Eigen::Index s = starts_[static_cast<std::size_t>(w)], end = starts_[static_cast<std::size_t>(w) + 1];
  const auto h = histories.segment(w * na_, na_);
  double sum = 0.0;
  const double root_rho = std::sqrt(penalty_);
  if (sensitivities) {
    local_g_.setZero();
    local_h_.setZero();
    in_block_ = 0;
  }
  // Gathers one residual r with gradient row_ over [θ; h_{w−1}; h_w] into the window's g and H.
  const auto add_residual = [&](double r) {
    local_g_.noalias() += r * row_;
    block_.col(in_block_++) = row_;
    if (in_block_ == block_.cols()) {
      local_h_.selfadjointView<Eigen::Lower>().rankUpdate(block_);
      in_block_ = 0;
    }
  };
  // Continuity: c_i = h_w[i] − ŷ_{w−1}(s − 1 − i), weighed by ρ (the previous window's tail from its sweep)
  if (w > 0) {
    for (int i = 0; i < na_; ++i) {
      const double c = h[i] - tail_y_[i];
      sum += penalty_ * c * c;
      if (sensitivities) {
        row_.head(P_ + na_) = -root_rho * tail_.col(i);  // −√ρ·dŷ/d[θ; h_{w−1}]
        row_.tail(na_).setZero();
        row_[P_ + na_ + i] = root_rho;
        add_residual(root_rho * c);
      }
    }
  }
  // sim_[na − 1 − i] = h_w[i]; sim_[na + (k − s)] = ŷ(k)
  for (int i = 0; i < na_; ++i) sim_[na_ - 1 - i] = h[i];
  if (sensitivities && na_ > 0) {
    // the recursion's start: dŷ(s−1−i)/dθ = 0, dŷ(s−1−i)/dh_w = e_i, in ring column (na − 1 − i) mod na
    ring_.setZero();
    for (int i = 0; i < na_; ++i) ring_(P_ + i, na_ - 1 - i) = 1.0;
  }
  for (Eigen::Index k = s; k < end; ++k) {
    const Eigen::Index m = na_ + (k - s);
    // [5G] x(k) = [ŷ(k−1..k−na), u(k−nk..k−nk−nb)], the outputs from the window's simulation and history
    fill_narx_regressor(
        na_, nb_, nk_, [&](int i) { return sim_[m - 1 - i]; },
        [&](int j) { return k - j >= 0 ? u_[k - j] : 0.0; }, x_);
    const double yk = model.net.forward(x_, ws_);
    sim_[m] = yk;
    const double e = yk - y_[k], wk = weight(k);
    sum += wk * e * e;
    if (!sensitivities) continue;
    model.net.backward(ws_, dtheta_, dx_);
    // [5L] over the stack: ψ(k) = [∂F/∂θ; 0] + Σ_{t=1}^{na} ∂F/∂ŷ(k−t)·ψ(k−t), ψ over [θ; h_w]
    row_.head(P_) = dtheta_;
    row_.tail(2 * na_).setZero();
    for (int t = 1; t <= na_; ++t) {
      const auto past = ring_.col((m - t) % na_);
      row_.head(P_).noalias() += dx_[t - 1] * past.head(P_);
      row_.tail(na_).noalias() += dx_[t - 1] * past.tail(na_);
    }
    if (na_ > 0) {
      ring_.col(m % na_).head(P_) = row_.head(P_);
      ring_.col(m % na_).tail(na_) = row_.tail(na_);
      if (k >= end - na_) {  // the next window's continuity reads these, newest first
        tail_.col(end - 1 - k) = ring_.col(m % na_);
      }
    }
    // [5M] the sample's residual √w·e with gradient √w·ψ
    const double root_w = std::sqrt(wk);
    row_ *= root_w;
    add_residual(root_w * e);
  }
  for (int i = 0; i < na_; ++i) tail_y_[i] = sim_[na_ + (end - s) - 1 - i];
  return sum;
}

double MultipleShooting::loss(const NarxModel& model, const Eigen::Ref<const Eigen::VectorXd>& histories) {
  double sum = 0.0;
  for (Eigen::Index w = 0; w < windows(); ++w) sum += window_sweep(model, histories, w, false);
  return 0.5 * sum / weight_total_;
}

double MultipleShooting::gradient(const NarxModel& model, const Eigen::Ref<const Eigen::VectorXd>& histories,
                                  Eigen::VectorXd& g, Eigen::MatrixXd* H) {
  const Eigen::Index n = P_ + na_ * windows();
  g.setZero(n);
  if (H != nullptr) H->setZero(n, n);
  double sum = 0.0;
  for (Eigen::Index w = 0; w < windows(); ++w) {
    sum += window_sweep(model, histories, w, true);
    // into the stack: θ at 0, h_{w−1} at P + na(w−1), h_w at P + na·w
    const Eigen::Index own = P_ + na_ * w, previous = own - na_;
    g.head(P_) += local_g_.head(P_);
    g.segment(own, na_) += local_g_.tail(na_);
    if (w > 0) g.segment(previous, na_) += local_g_.segment(P_, na_);
    if (H == nullptr) continue;
    if (in_block_ > 0) local_h_.selfadjointView<Eigen::Lower>().rankUpdate(block_.leftCols(in_block_));
    local_h_.triangularView<Eigen::StrictlyUpper>() = local_h_.transpose();
    add_block(*H, local_h_, 0, 0, 0, 0, P_, P_);
    add_block(*H, local_h_, own, own, P_ + na_, P_ + na_, na_, na_);
    add_block(*H, local_h_, own, 0, P_ + na_, 0, na_, P_);
    if (w > 0) {
      add_block(*H, local_h_, previous, previous, P_, P_, na_, na_);
      add_block(*H, local_h_, previous, 0, P_, 0, na_, P_);
      add_block(*H, local_h_, own, previous, P_ + na_, P_, na_, na_);
    }
  }
  g /= weight_total_;
  if (H != nullptr) *H /= weight_total_;
  return 0.5 * sum / weight_total_;
}

}  // namespace panelbass::models

#include "models/linear/state_space_runner.h"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace panelbass::models {

StateSpaceRunner::StateSpaceRunner(StateSpace system, const Eigen::VectorXd& x0, BlockForm block_form)
    : system_(std::move(system)) {
  check_shape(system_, "state-space runner");
  const Eigen::Index n = system_.order();
  if (x0.size() != 0 && x0.size() != n) {
    throw std::invalid_argument("state-space runner: initial state has " + std::to_string(x0.size()) +
                                " entries, the system has " + std::to_string(n) + " states");
  }
  c_ = system_.C.transpose();
  x_ = x0.size() == 0 ? Eigen::VectorXd::Zero(n) : x0;
  next_ = Eigen::VectorXd::Zero(n);
  stride_ = (n + 3) / 4 * 4;
  // stride_ columns of A (the padding columns and rows zero), then B, then Cᵀ, each stride_ long.
  packed_.assign(static_cast<std::size_t>(stride_ * (stride_ + 2)), 0.0);
  for (Eigen::Index j = 0; j < n; ++j) {
    for (Eigen::Index i = 0; i < n; ++i) packed_[static_cast<std::size_t>(j * stride_ + i)] = system_.A(i, j);
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    packed_[static_cast<std::size_t>(stride_ * stride_ + i)] = system_.B[i];
    packed_[static_cast<std::size_t>((stride_ + 1) * stride_ + i)] = c_[i];
  }
  if (block_form == BlockForm::modal && n > 0 && n <= 16) prepare_modal_form();
}

void StateSpaceRunner::prepare_modal_form() {
  const Eigen::Index n = system_.order();
  if (!system_.A.allFinite() || !system_.B.allFinite() || !system_.C.allFinite()) return;
  // A = V·Λ·V⁻¹ with Λ real block diagonal: 1×1 blocks (real poles) and 2×2 blocks [σ ω; −ω σ].
  const Eigen::EigenSolver<Eigen::MatrixXd> eigen(system_.A);
  if (eigen.info() != Eigen::Success) return;
  const Eigen::MatrixXd V = eigen.pseudoEigenvectors();
  const Eigen::MatrixXd L = eigen.pseudoEigenvalueMatrix();
  const Eigen::VectorXd sv = Eigen::JacobiSVD<Eigen::MatrixXd>(V).singularValues();
  // Rounding in modal coordinates grows by up to κ(V) on the way back: only a well-conditioned V is used.
  if (!(sv[n - 1] > 0.0) || sv[0] > 100.0 * sv[n - 1]) return;
  const Eigen::MatrixXd V_inv = V.partialPivLu().inverse();
  // Lanes: each complex pair's two states, then the real poles two at a time (the last padded with a zero state).
  std::vector<std::pair<Eigen::Index, Eigen::Index>> lanes;  // (state, its partner in the block; −1: none)
  std::vector<Eigen::Index> reals;
  for (Eigen::Index i = 0; i < n;) {
    if (i + 1 < n && L(i, i + 1) != 0.0) {
      lanes.emplace_back(i, i + 1);
      lanes.emplace_back(i + 1, i);
      i += 2;
    } else {
      reals.push_back(i++);
    }
  }
  for (const Eigen::Index r : reals) lanes.emplace_back(r, -1);
  if (lanes.size() % 2 != 0) lanes.emplace_back(-1, -1);
  const auto width = static_cast<Eigen::Index>(lanes.size());
  to_modal_ = Eigen::MatrixXd::Zero(width, n);
  from_modal_ = Eigen::MatrixXd::Zero(n, width);
  std::vector<double> modal(static_cast<std::size_t>(4 * width), 0.0);
  for (Eigen::Index lane = 0; lane < width; ++lane) {
    const auto [state, partner] = lanes[static_cast<std::size_t>(lane)];
    if (state < 0) continue;
    to_modal_.row(lane) = V_inv.row(state);
    from_modal_.col(lane) = V.col(state);
    modal[static_cast<std::size_t>(lane)] = L(state, state);
    if (partner >= 0) modal[static_cast<std::size_t>(width + lane)] = L(state, partner);
  }
  const Eigen::VectorXd b = to_modal_ * system_.B;
  const Eigen::RowVectorXd c = system_.C * from_modal_;
  for (Eigen::Index lane = 0; lane < width; ++lane) {
    modal[static_cast<std::size_t>(2 * width + lane)] = b[lane];
    modal[static_cast<std::size_t>(3 * width + lane)] = c[lane];
  }
  // Both forms' impulse responses over 2048 samples: the modal one is used only if their difference, summed,
  // is within 1e-13 of the response's own sum. The output of any input is a sum of shifted, scaled impulse
  // responses, so no output then moves by more than 1e-13 of the largest the system can give that input.
  StateSpaceRunner dense(system_), modal_runner(system_);
  modal_runner.modal_pairs_ = static_cast<int>(width / 2);
  modal_runner.modal_ = modal;
  modal_runner.to_modal_ = to_modal_;
  modal_runner.from_modal_ = from_modal_;
  modal_runner.z_ = Eigen::VectorXd::Zero(width);
  std::vector<double> impulse(2048, 0.0), h_modal(impulse.size());
  impulse[0] = 1.0;
  modal_runner.step_block(impulse, h_modal);
  double sum = 0.0, difference = 0.0;
  for (std::size_t k = 0; k < impulse.size(); ++k) {
    const double h = dense.step(impulse[k]);
    sum += std::abs(h);
    difference += std::abs(h - h_modal[k]);
  }
  if (!(difference <= 1e-13 * sum)) return;
  modal_pairs_ = static_cast<int>(width / 2);
  modal_ = std::move(modal);
  z_ = Eigen::VectorXd::Zero(width);
}

namespace {

// Two doubles, one SSE2 register (GCC's vector extension: every x86-64 has it; elsewhere the compiler
// splits it as the target needs).
using Pair = double __attribute__((vector_size(16)));

// step_block for S states (S a multiple of 4; padded with zero states whose columns and rows are zero): the
// state and its update in S/2 registers, every loop of a length known here and unrolled.
template <int S>
void step_block_fixed(const double* packed, int n, double d, double* state, std::span<const double> in,
                      std::span<double> out) noexcept {
  constexpr int V = S / 2;
  Pair x[V], a[S][V], b[V], c[V];
  for (int i = 0; i < V; ++i) {
    x[i] = Pair{2 * i < n ? state[2 * i] : 0.0, 2 * i + 1 < n ? state[2 * i + 1] : 0.0};
    b[i] = Pair{packed[S * S + 2 * i], packed[S * S + 2 * i + 1]};
    c[i] = Pair{packed[S * S + S + 2 * i], packed[S * S + S + 2 * i + 1]};
  }
  for (int j = 0; j < S; ++j) {
    for (int i = 0; i < V; ++i) a[j][i] = Pair{packed[j * S + 2 * i], packed[j * S + 2 * i + 1]};
  }
  for (std::size_t k = 0; k < in.size(); ++k) {
    const double u = in[k];
    // y(k) = C·x(k) + D·u(k), in two-lane partial sums
    Pair lanes = c[0] * x[0];
#pragma GCC unroll 16
    for (int i = 1; i < V; ++i) lanes += c[i] * x[i];
    // x(k+1) = A·x(k) + B·u(k), column by column in two interleaved sums (even and odd columns), so the
    // additions overlap instead of queuing one after another
    Pair next[V], odd[V];
#pragma GCC unroll 16
    for (int i = 0; i < V; ++i) {
      next[i] = b[i] * u;
      odd[i] = a[1][i] * x[0][1];
    }
#pragma GCC unroll 16
    for (int j = 0; j < S; j += 2) {
#pragma GCC unroll 16
      for (int i = 0; i < V; ++i) {
        next[i] += a[j][i] * x[j / 2][0];
        if (j > 0) odd[i] += a[j + 1][i] * x[j / 2][1];
      }
    }
#pragma GCC unroll 16
    for (int i = 0; i < V; ++i) x[i] = next[i] + odd[i];
    out[k] = (lanes[0] + lanes[1]) + d * u;
  }
  for (int i = 0; i < n; ++i) state[i] = x[i / 2][i % 2];
}

// step_block in modal coordinates for P pairs of states: per pair z ← diag∘z + cross∘swap(z) + b·u, so
// each state waits for one multiply and two adds per sample instead of a sum over every state.
template <int P>
void step_block_modal(const double* modal, double d, double* z, std::span<const double> in,
                      std::span<double> out) noexcept {
  constexpr int W = 2 * P;
  Pair s[P], diag[P], cross[P], b[P], c[P];
  for (int i = 0; i < P; ++i) {
    s[i] = Pair{z[2 * i], z[2 * i + 1]};
    diag[i] = Pair{modal[2 * i], modal[2 * i + 1]};
    cross[i] = Pair{modal[W + 2 * i], modal[W + 2 * i + 1]};
    b[i] = Pair{modal[2 * W + 2 * i], modal[2 * W + 2 * i + 1]};
    c[i] = Pair{modal[3 * W + 2 * i], modal[3 * W + 2 * i + 1]};
  }
  for (std::size_t k = 0; k < in.size(); ++k) {
    const double u = in[k];
    // y(k) = C·T·z(k) + D·u(k)
    Pair lanes = c[0] * s[0];
#pragma GCC unroll 8
    for (int i = 1; i < P; ++i) lanes += c[i] * s[i];
    // z(k+1) = Λ·z(k) + T⁻¹B·u(k), Λ block diagonal
#pragma GCC unroll 8
    for (int i = 0; i < P; ++i) s[i] = (diag[i] * s[i] + b[i] * u) + cross[i] * Pair{s[i][1], s[i][0]};
    out[k] = (lanes[0] + lanes[1]) + d * u;
  }
  for (int i = 0; i < P; ++i) {
    z[2 * i] = s[i][0];
    z[2 * i + 1] = s[i][1];
  }
}

}  // namespace

void StateSpaceRunner::step_block(std::span<const double> in, std::span<double> out) noexcept {
  const int n = order();
  double* state = x_.data();
  if (modal_pairs_ > 0) {
    // Into modal coordinates, the block, and back: 2·n·2P multiply-adds a block.
    z_.noalias() = to_modal_ * x_;
    switch (modal_pairs_) {
      case 1: step_block_modal<1>(modal_.data(), system_.D, z_.data(), in, out); break;
      case 2: step_block_modal<2>(modal_.data(), system_.D, z_.data(), in, out); break;
      case 3: step_block_modal<3>(modal_.data(), system_.D, z_.data(), in, out); break;
      case 4: step_block_modal<4>(modal_.data(), system_.D, z_.data(), in, out); break;
      case 5: step_block_modal<5>(modal_.data(), system_.D, z_.data(), in, out); break;
      case 6: step_block_modal<6>(modal_.data(), system_.D, z_.data(), in, out); break;
      case 7: step_block_modal<7>(modal_.data(), system_.D, z_.data(), in, out); break;
      default: step_block_modal<8>(modal_.data(), system_.D, z_.data(), in, out); break;
    }
    x_.noalias() = from_modal_ * z_;
    return;
  }
  switch (stride_) {
    case 0:
      for (std::size_t k = 0; k < in.size(); ++k) out[k] = system_.D * in[k];
      return;
    case 4:
      return step_block_fixed<4>(packed_.data(), n, system_.D, state, in, out);
    case 8:
      return step_block_fixed<8>(packed_.data(), n, system_.D, state, in, out);
    case 12:
      return step_block_fixed<12>(packed_.data(), n, system_.D, state, in, out);
    case 16:
      return step_block_fixed<16>(packed_.data(), n, system_.D, state, in, out);
    default:
      for (std::size_t k = 0; k < in.size(); ++k) out[k] = step(in[k]);
  }
}

}  // namespace panelbass::models

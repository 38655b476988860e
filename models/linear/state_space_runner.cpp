#include "models/linear/state_space_runner.h"

#include <stdexcept>
#include <string>
#include <utility>

namespace panelbass::models {

StateSpaceRunner::StateSpaceRunner(StateSpace system, const Eigen::VectorXd& x0)
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

}  // namespace

void StateSpaceRunner::step_block(std::span<const double> in, std::span<double> out) noexcept {
  const int n = order();
  double* state = x_.data();
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

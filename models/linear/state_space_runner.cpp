#include "models/linear/state_space_runner.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

namespace panelbass::models {

StateSpaceRunner::StateSpaceRunner(StateSpace system, const Eigen::VectorXd& x0) : system_(std::move(system)) {
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
  packed_.assign(static_cast<std::size_t>(stride_ * (n + 2)), 0.0);
  for (Eigen::Index j = 0; j < n; ++j) {
    for (Eigen::Index i = 0; i < n; ++i) packed_[static_cast<std::size_t>(j * stride_ + i)] = system_.A(i, j);
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    packed_[static_cast<std::size_t>(n * stride_ + i)] = system_.B[i];
    packed_[static_cast<std::size_t>((n + 1) * stride_ + i)] = c_[i];
  }
}

namespace {

// step_block for a state of at most S states (S a multiple of 4, zero-padded), the state in a local array
// the compiler keeps in vector registers.
template <int S>
void step_block_fixed(const double* packed, int n, double d, double* state, std::span<const double> in,
                      std::span<double> out) noexcept {
  double x[S], next[S];
  std::fill_n(x, S, 0.0);
  std::copy_n(state, n, x);
  const double* b = packed + n * S;
  const double* c = b + S;
  for (std::size_t k = 0; k < in.size(); ++k) {
    const double u = in[k];
    // y(k) = C·x(k) + D·u(k), in four partial sums
    double lanes[4] = {0.0, 0.0, 0.0, 0.0};
    for (int i = 0; i < S; i += 4) {
      for (int t = 0; t < 4; ++t) lanes[t] += c[i + t] * x[i + t];
    }
    out[k] = ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) + d * u;
    // x(k+1) = A·x(k) + B·u(k), column by column
    for (int i = 0; i < S; ++i) next[i] = b[i] * u;
    for (int j = 0; j < n; ++j) {
      const double* a = packed + j * S;
      const double xj = x[j];
      for (int i = 0; i < S; ++i) next[i] += a[i] * xj;
    }
    std::copy_n(next, S, x);
  }
  std::copy_n(x, n, state);
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

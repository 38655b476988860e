#include "models/narx/mlp_kernel.h"

#include <Eigen/Core>
#include <algorithm>

namespace panelbass::models {

void tanh_in_place(std::span<double> x) noexcept {
  Eigen::Map<Eigen::ArrayXd> a(x.data(), static_cast<Eigen::Index>(x.size()));
  // tanh(x) = 1 − 2/(e^{2x} + 1): no cancellation for large |x|, and near 0 the absolute error stays at the
  // rounding of e^{2x} (≈ 2e-16); e^{2x} saturates (Eigen clamps the exponent) so ±∞ give ±1. Eigen's exp
  // clamps a NaN too, so NaN is put back explicitly: a NaN must reach the limiter as a NaN.
  a = (a == a).select(1.0 - 2.0 / ((2.0 * a).exp() + 1.0), a);
}

bool avx2_fma_available() noexcept {
#if defined(__x86_64__) || defined(__i386__)
  static const bool available = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return available;
#else
  return false;
#endif
}

void tanh_in_place(std::span<double> x, SimdLevel level) noexcept {
  if (level == SimdLevel::best) level = avx2_fma_available() ? SimdLevel::avx2_fma : SimdLevel::baseline;
  if (level == SimdLevel::avx2_fma) {
    detail::tanh_avx2_fma(x);
  } else {
    tanh_in_place(x);
  }
}

MlpKernel::MlpKernel(const Mlp& net, SimdLevel level) : inputs_(net.inputs()) {
  if (level == SimdLevel::best || (level == SimdLevel::avx2_fma && !avx2_fma_available())) {
    level = avx2_fma_available() ? SimdLevel::avx2_fma : SimdLevel::baseline;
  }
  level_ = level;
  const double* p = net.parameters().data();
  std::size_t n_in = static_cast<std::size_t>(net.inputs());
  std::size_t activations = 0;
  for (int width : net.hidden()) {
    detail::KernelLayer layer;
    layer.inputs = n_in;
    layer.nodes = static_cast<std::size_t>(width);
    layer.stride = (layer.nodes + 3) / 4 * 4;
    layer.weights = weights_.size();
    layer.bias = layer.weights + layer.stride * n_in;
    layer.out = activations;
    weights_.resize(layer.bias + layer.stride, 0.0);
    // θ holds row i = node i's input weights, then the biases; here column j = input j's weights.
    for (std::size_t i = 0; i < layer.nodes; ++i) {
      for (std::size_t j = 0; j < n_in; ++j) weights_[layer.weights + j * layer.stride + i] = p[i * n_in + j];
      weights_[layer.bias + i] = p[layer.nodes * n_in + i];
    }
    p += layer.nodes * (n_in + 1);
    activations += layer.stride;
    layers_.push_back(layer);
    n_in = layer.nodes;
  }
  activations_.assign(activations, 0.0);
  // The output node's weights padded with zeros to a multiple of 4 (the padded activations are tanh(0) = 0),
  // then its bias.
  const std::size_t padded = (n_in + 3) / 4 * 4;
  output_.assign(padded + 1, 0.0);
  std::copy(p, p + n_in, output_.begin());
  output_.back() = p[n_in];
  make_view();
}

MlpKernel& MlpKernel::operator=(const MlpKernel& other) {
  if (this == &other) return *this;
  inputs_ = other.inputs_;
  level_ = other.level_;
  layers_ = other.layers_;
  weights_ = other.weights_;
  activations_ = other.activations_;
  output_ = other.output_;
  make_view();
  return *this;
}

void MlpKernel::make_view() noexcept {
  view_ = {layers_.data(), layers_.size(), weights_.data(), activations_.data(), output_.data(),
           layers_.empty() ? static_cast<std::size_t>(inputs_) : layers_.back().nodes};
}

namespace {

// node_in[r..r+4) += Σ_j column j's rows r..r+4 · x[j], columns from `w` on (stride apart); returns the
// pointer past the last column read. Four independent sums: the compiler keeps them in vector registers.
const double* accumulate4(double (&sum)[4], const double* w, std::size_t stride, std::span<const double> x) noexcept {
  for (const double xj : x) {
    for (int t = 0; t < 4; ++t) sum[t] += w[t] * xj;
    w += stride;
  }
  return w;
}

}  // namespace

void MlpKernel::free_run(NarxHistory& history, std::span<const double> u, std::span<double> y) noexcept {
  if (level_ == SimdLevel::avx2_fma) {
    detail::free_run_avx2_fma(view_, history, u, y);
    return;
  }
  for (std::size_t k = 0; k < u.size(); ++k) {
    history.push_input(u[k]);
    y[k] = forward_baseline(history.past_outputs(), history.past_inputs());
    history.push_output(y[k]);
  }
}

double MlpKernel::forward_baseline(std::span<const double> head, std::span<const double> tail) noexcept {
  if (layers_.empty()) {
    // No hidden layer: F = w_out·x + b_out.
    double f = output_.back();
    for (std::size_t j = 0; j < head.size(); ++j) f += output_[j] * head[j];
    for (std::size_t j = 0; j < tail.size(); ++j) f += output_[head.size() + j] * tail[j];
    return f;
  }
  std::span<const double> previous;
  for (std::size_t l = 0; l < layers_.size(); ++l) {
    const detail::KernelLayer& layer = layers_[l];
    double* node = activations_.data() + layer.out;
    // [fig 5.6] node_in = W·x + b, node_out = tanh(node_in); four nodes at a time, column by column
    for (std::size_t r = 0; r < layer.stride; r += 4) {
      double sum[4];
      std::copy_n(weights_.data() + layer.bias + r, 4, sum);
      const double* w = weights_.data() + layer.weights + r;
      if (l == 0) {
        // head[0] (a NARX's y(k−1), the newest feedback) last: everything else is summed before it is known.
        const std::span<const double> newest = head.first(std::min<std::size_t>(1, head.size()));
        accumulate4(sum, accumulate4(sum, w + newest.size() * layer.stride, layer.stride, head.subspan(newest.size())),
                    layer.stride, tail);
        accumulate4(sum, w, layer.stride, newest);
      } else {
        accumulate4(sum, w, layer.stride, previous);
      }
      std::copy_n(sum, 4, node + r);
    }
    tanh_in_place({node, layer.nodes});
    previous = {node, layer.nodes};
  }
  // Linear output node: F = w_out·a + b_out
  double f = output_.back();
  for (std::size_t j = 0; j < previous.size(); ++j) f += output_[j] * previous[j];
  return f;
}

}  // namespace panelbass::models

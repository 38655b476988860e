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

MlpKernel::MlpKernel(const Mlp& net) : inputs_(net.inputs()) {
  const double* p = net.parameters().data();
  std::size_t n_in = static_cast<std::size_t>(net.inputs());
  std::size_t activations = 0;
  for (int width : net.hidden()) {
    Layer layer;
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
  output_.assign(p, p + n_in + 1);
}

void MlpKernel::accumulate(const Layer& layer, std::span<const double> x, std::size_t first) noexcept {
  // node_in += W[:, first..]·x, column-major over contiguous padded columns (Eigen's vectorised product).
  const auto stride = static_cast<Eigen::Index>(layer.stride);
  const auto n = static_cast<Eigen::Index>(x.size());
  Eigen::Map<Eigen::VectorXd> node_in(activations_.data() + layer.out, stride);
  const Eigen::Map<const Eigen::MatrixXd> w(weights_.data() + layer.weights + first * layer.stride, stride, n);
  node_in.noalias() += w * Eigen::Map<const Eigen::VectorXd>(x.data(), n);
}

double MlpKernel::forward(std::span<const double> head, std::span<const double> tail) noexcept {
  if (layers_.empty()) {
    // No hidden layer: F = w_out·x + b_out.
    double f = output_.back();
    for (std::size_t j = 0; j < head.size(); ++j) f += output_[j] * head[j];
    for (std::size_t j = 0; j < tail.size(); ++j) f += output_[head.size() + j] * tail[j];
    return f;
  }
  std::span<const double> previous;
  for (std::size_t l = 0; l < layers_.size(); ++l) {
    const Layer& layer = layers_[l];
    double* node_in = activations_.data() + layer.out;
    std::copy_n(weights_.data() + layer.bias, layer.stride, node_in);
    // [fig 5.6] node_in = W·x + b, node_out = tanh(node_in)
    if (l == 0) {
      accumulate(layer, head, 0);
      accumulate(layer, tail, head.size());
    } else {
      accumulate(layer, previous, 0);
    }
    tanh_in_place({node_in, layer.nodes});
    previous = {node_in, layer.nodes};
  }
  // Linear output node: F = w_out·a + b_out
  double f = output_.back();
  for (std::size_t j = 0; j < previous.size(); ++j) f += output_[j] * previous[j];
  return f;
}

}  // namespace panelbass::models

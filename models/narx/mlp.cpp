#include "models/narx/mlp.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "dsp/random.h"

namespace panelbass::models {
namespace {

// One layer's weights as stored in θ: row i holds node i's input weights.
using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using ConstLayerWeights = Eigen::Map<const RowMajorMatrix>;
using LayerWeights = Eigen::Map<RowMajorMatrix>;
using ConstVectorMap = Eigen::Map<const Eigen::VectorXd>;

}  // namespace

Mlp::Mlp(int inputs, std::vector<int> hidden) : inputs_(inputs), hidden_(std::move(hidden)) {
  if (inputs_ < 1) throw std::invalid_argument("Mlp: inputs must be >= 1, got " + std::to_string(inputs_));
  Eigen::Index previous = inputs_;
  for (std::size_t l = 0; l < hidden_.size(); ++l) {
    if (hidden_[l] < 1) {
      throw std::invalid_argument("Mlp: hidden layer " + std::to_string(l) + " must have >= 1 nodes, got " +
                                  std::to_string(hidden_[l]));
    }
    parameter_count_ += (previous + 1) * hidden_[l];
    previous = hidden_[l];
  }
  parameter_count_ += previous + 1;  // the linear output node
  theta_ = Eigen::VectorXd::Zero(parameter_count_);
}

void Mlp::initialize(double input_max, std::uint64_t seed, double scale) {
  if (!(input_max > 0.0) || !std::isfinite(input_max)) {
    throw std::invalid_argument("Mlp::initialize: input_max must be finite and > 0, got " + std::to_string(input_max));
  }
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    throw std::invalid_argument("Mlp::initialize: scale must be finite and > 0, got " + std::to_string(scale));
  }
  dsp::Rng rng(seed);
  double* p = theta_.data();
  Eigen::Index n_in = inputs_;
  // [5F] first layer: Max = 2 / (Input_max·#Inputs + bias), bias = 1
  double max = scale * 2.0 / (input_max * static_cast<double>(inputs_) + 1.0);
  for (std::size_t l = 0; l <= hidden_.size(); ++l) {
    const Eigen::Index n_out = l < hidden_.size() ? hidden_[l] : 1;
    // Weights and biases alike: |node_in| ≤ Σ|w|·|x| + |b|·1 < Max·(Σ|x| + 1) ≤ 2.
    const Eigen::Index count = n_out * (n_in + 1);
    for (Eigen::Index i = 0; i < count; ++i) *p++ = rng.uniform(-max, max);
    // [5F] next layers (the output layer too): Max = 2 / (#Nodes_prev + bias), since |tanh| < 1
    max = scale * 2.0 / (static_cast<double>(n_out) + 1.0);
    n_in = n_out;
  }
}

bool Mlp::fits(const Workspace& ws) const noexcept {
  if (ws.input.size() != inputs_ || ws.activation.size() != hidden_.size() || ws.delta.size() != hidden_.size()) {
    return false;
  }
  for (std::size_t l = 0; l < hidden_.size(); ++l) {
    if (ws.activation[l].size() != hidden_[l] || ws.delta[l].size() != hidden_[l]) return false;
  }
  return true;
}

Mlp::Workspace Mlp::workspace() const {
  Workspace ws;
  ws.input = Eigen::VectorXd::Zero(inputs_);
  ws.activation.reserve(hidden_.size());
  ws.delta.reserve(hidden_.size());
  for (int width : hidden_) {
    ws.activation.push_back(Eigen::VectorXd::Zero(width));
    ws.delta.push_back(Eigen::VectorXd::Zero(width));
  }
  return ws;
}

double Mlp::forward(const Eigen::Ref<const Eigen::VectorXd>& x, Workspace& ws) const {
  if (x.size() != inputs_) {
    throw std::invalid_argument("Mlp::forward: input has " + std::to_string(x.size()) + " entries, the network " +
                                std::to_string(inputs_));
  }
  // A workspace that does not fit (default-constructed, or from another network) is sized once here.
  if (!fits(ws)) ws = workspace();
  return forward_unchecked(x, ws);
}

double Mlp::forward_unchecked(const Eigen::Ref<const Eigen::VectorXd>& x, Workspace& ws) const noexcept {
  ws.input = x;
  const double* p = theta_.data();
  const Eigen::VectorXd* previous = &ws.input;
  for (std::size_t l = 0; l < hidden_.size(); ++l) {
    const Eigen::Index n_in = previous->size();
    const Eigen::Index n_out = hidden_[l];
    const ConstLayerWeights w(p, n_out, n_in);
    const ConstVectorMap b(p + n_out * n_in, n_out);
    p += n_out * (n_in + 1);
    Eigen::VectorXd& a = ws.activation[l];
    // [fig 5.6] node_in = W·x + b, node_out = tanh(node_in)
    a.noalias() = w * (*previous);
    a = (a + b).array().tanh().matrix();
    previous = &a;
  }
  // Linear output node: F = w_out·a + b_out
  const Eigen::Index n_last = previous->size();
  return ConstVectorMap(p, n_last).dot(*previous) + p[n_last];
}

void Mlp::backward(Workspace& ws, Eigen::Ref<Eigen::VectorXd> dtheta, Eigen::Ref<Eigen::VectorXd> dx) const {
  if (dtheta.size() != parameter_count_) {
    throw std::invalid_argument("Mlp::backward: dtheta has " + std::to_string(dtheta.size()) + " entries, P = " +
                                std::to_string(parameter_count_));
  }
  if (dx.size() != 0 && dx.size() != inputs_) {
    throw std::invalid_argument("Mlp::backward: dx has " + std::to_string(dx.size()) + " entries, the network " +
                                std::to_string(inputs_) + " inputs");
  }
  if (!fits(ws)) throw std::invalid_argument("Mlp::backward: the workspace is not from forward()");

  const std::size_t layers = hidden_.size();
  const Eigen::VectorXd& last = layers > 0 ? ws.activation[layers - 1] : ws.input;
  const Eigen::Index n_last = last.size();
  Eigen::Index offset = parameter_count_ - (n_last + 1);
  // Output node: ∂F/∂w_out = a_last, ∂F/∂b_out = 1
  dtheta.segment(offset, n_last) = last;
  dtheta[offset + n_last] = 1.0;
  const ConstVectorMap w_out(theta_.data() + offset, n_last);
  if (layers == 0) {
    if (dx.size() != 0) dx = w_out;
    return;
  }
  // δ_last = ∂F/∂node_in = w_out ⊙ (1 − a²)   (tanh' = 1 − tanh²)
  ws.delta[layers - 1] = w_out.cwiseProduct((1.0 - last.array().square()).matrix());
  for (std::size_t l = layers; l-- > 0;) {
    const Eigen::VectorXd& previous = l > 0 ? ws.activation[l - 1] : ws.input;
    const Eigen::Index n_in = previous.size();
    const Eigen::Index n_out = hidden_[l];
    offset -= n_out * (n_in + 1);
    const Eigen::VectorXd& delta = ws.delta[l];
    // ∂F/∂W_l = δ_l·a_{l−1}ᵀ (row by row, as in θ), ∂F/∂b_l = δ_l
    LayerWeights(dtheta.data() + offset, n_out, n_in).noalias() = delta * previous.transpose();
    dtheta.segment(offset + n_out * n_in, n_out) = delta;
    const ConstLayerWeights w(theta_.data() + offset, n_out, n_in);
    if (l > 0) {
      // δ_{l−1} = (W_lᵀ·δ_l) ⊙ (1 − a_{l−1}²)
      Eigen::VectorXd& below = ws.delta[l - 1];
      below.noalias() = w.transpose() * delta;
      below.array() *= 1.0 - previous.array().square();
    } else if (dx.size() != 0) {
      // ∂F/∂x = W_0ᵀ·δ_0
      dx.noalias() = w.transpose() * delta;
    }
  }
}

}  // namespace panelbass::models

#pragma once
// The MLP of mlp.h prepared for the engine's per-sample path: contiguous column-major weights and a
// vectorised tanh, so one evaluation is a few vector multiply-adds per input and no call per neuron.

#include <cstddef>
#include <span>
#include <vector>

#include "models/narx/mlp.h"

namespace panelbass::models {

/// tanh of each entry in place, vectorised: 1 − 2/(e^{2x} + 1) with Eigen's packet exp. Within 1e-15 of
/// std::tanh (absolute), exactly ±1 beyond |x| ≈ 19, NaN for NaN; never allocates.
void tanh_in_place(std::span<double> x) noexcept;

/// An Mlp prepared for the real-time path: its weights copied once, column by column, into padded
/// contiguous storage, so a layer is a run of vector multiply-adds (one column per input) and one
/// vectorised tanh (tanh_in_place), with no call per neuron and no allocation. Its output is the Mlp's
/// within rounding (a few 1e-16: the sums run in another order and tanh_in_place is not std::tanh).
class MlpKernel {
 public:
  /// No network: forward() returns 0.
  MlpKernel() = default;
  /// The kernel of `net` (a copy of its weights as they are now).
  explicit MlpKernel(const Mlp& net);

  /// Number of inputs.
  int inputs() const { return inputs_; }
  /// F(x) for x = head followed by tail (head.size() + tail.size() == inputs(), which the caller checked
  /// once when it was prepared), so a regressor kept in two histories needs no copy.
  double forward(std::span<const double> head, std::span<const double> tail) noexcept;

 private:
  struct Layer {
    std::size_t inputs = 0, nodes = 0, stride = 0;  // stride: nodes rounded up to a multiple of 4
    std::size_t weights = 0, bias = 0, out = 0;     // offsets into weights_ and activations_
  };
  // Adds Σ_j x[j]·column j of `layer` (columns `first`.. on) to its node inputs.
  void accumulate(const Layer& layer, std::span<const double> x, std::size_t first) noexcept;

  int inputs_ = 0;
  std::vector<Layer> layers_;
  std::vector<double> weights_;      // per layer: the weight columns (stride each), then the biases
  std::vector<double> activations_;  // per layer: stride node values
  std::vector<double> output_;       // the linear output node's weights, then its bias
};

}  // namespace panelbass::models

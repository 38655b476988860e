#pragma once
// The multilayer perceptron of the thesis (ch. 5, fig. 5.6): tanh hidden layers, one linear output,
// every weight in one flat parameter vector θ.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace panelbass::models {

/// A network NN_{i0 i1 … 1}: `inputs` inputs, hidden tanh layers of the given widths, one linear output.
/// θ holds, layer after layer, the weight matrix row by row (row = one node's input weights) followed by
/// that layer's biases; the output layer last.
class Mlp {
 public:
  /// Activations of one evaluation, sized once by workspace(); forward() fills it, backward() reads it.
  struct Workspace {
    std::vector<Eigen::VectorXd> activation;  ///< per hidden layer: tanh outputs
    std::vector<Eigen::VectorXd> delta;       ///< per hidden layer: back-propagated sensitivities
    Eigen::VectorXd input;                    ///< the input of the last forward()
  };

  /// A network with all weights zero. Throws std::invalid_argument for inputs < 1 or a width < 1.
  Mlp(int inputs, std::vector<int> hidden);

  /// Number of inputs.
  int inputs() const { return inputs_; }
  /// Widths of the hidden layers.
  const std::vector<int>& hidden() const { return hidden_; }
  /// Number of parameters P.
  Eigen::Index parameter_count() const { return parameter_count_; }
  /// θ.
  const Eigen::VectorXd& parameters() const { return theta_; }
  /// θ, to change (its size must stay P).
  Eigen::VectorXd& parameters() { return theta_; }

  /// [5F] Random initial weights, uniform in ±max with max = 2/(input_max·inputs + 1) for the first
  /// layer and 2/(nodes_prev + 1) for the next ones, so that no node input leaves (−2, 2) at the start;
  /// `scale` multiplies max (the thesis's "large initial weights" experiment uses scale ≫ 1).
  void initialize(double input_max, std::uint64_t seed, double scale = 1.0);

  /// A workspace of the right sizes.
  Workspace workspace() const;

  /// True when `ws` has the sizes workspace() gives (so forward_unchecked() may use it).
  bool fits(const Workspace& ws) const noexcept;

  /// F(x): the output for input x (size inputs()); fills `ws` for backward(). Checks x's size (throws
  /// std::invalid_argument) and sizes a workspace that does not fit.
  double forward(const Eigen::Ref<const Eigen::VectorXd>& x, Workspace& ws) const;

  /// F(x) for the real-time path: the same numbers as forward(), without its checks, never allocating.
  /// Requires x.size() == inputs() and fits(ws), which the caller checked once when it was prepared.
  double forward_unchecked(const Eigen::Ref<const Eigen::VectorXd>& x, Workspace& ws) const noexcept;

  /// After forward(x, ws): ∂F/∂θ into `dtheta` (size P) and ∂F/∂x into `dx` (size inputs(); may be
  /// empty to skip). No allocation.
  void backward(Workspace& ws, Eigen::Ref<Eigen::VectorXd> dtheta, Eigen::Ref<Eigen::VectorXd> dx) const;

 private:
  int inputs_;
  std::vector<int> hidden_;
  Eigen::Index parameter_count_ = 0;
  Eigen::VectorXd theta_;
};

}  // namespace panelbass::models

#pragma once
// Adam (Kingma & Ba 2015): the first-order stochastic optimiser the neural state-space model's training
// runs for the bulk of its iterations on mini-batches of simulation windows.

#include <Eigen/Core>

namespace panelbass::models {

/// Adam's settings.
struct AdamOptions {
  double learning_rate = 1e-3;  ///< step size α
  double beta1 = 0.9;           ///< decay of the first moment
  double beta2 = 0.999;         ///< decay of the second moment
  double epsilon = 1e-8;        ///< added to √v
};

/// Adam's moments for one parameter vector; step() moves θ against a gradient.
class Adam {
 public:
  /// Moments of zero for `parameters` parameters.
  explicit Adam(Eigen::Index parameters, AdamOptions options = {});

  /// θ ← θ − α·m̂/(√v̂ + ε) with the bias-corrected moments of `gradient` (same size as θ).
  void step(Eigen::Ref<Eigen::VectorXd> theta, const Eigen::VectorXd& gradient);

  /// The settings, to change the learning rate between steps.
  AdamOptions& options() { return options_; }

 private:
  AdamOptions options_;
  Eigen::VectorXd m_, v_;
  long t_ = 0;
};

}  // namespace panelbass::models

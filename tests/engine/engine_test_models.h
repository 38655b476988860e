#pragma once
// Models and signals the engine tests share: small, fixed, at the thesis's 3000 Hz.

#include <Eigen/Core>
#include <cmath>
#include <complex>
#include <cstdint>
#include <numbers>
#include <span>
#include <vector>

#include "dsp/random.h"
#include "models/linear/linear_model.h"
#include "models/control/feedback_training.h"
#include "models/narx/narx_model.h"
#include "models/control/lq_feedforward.h"
#include "models/control/neural_feedback.h"
#include "models/linear/transfer_function.h"

namespace panelbass::engine::testing {

/// The model rate of every engine test.
inline constexpr double kFs = 3000.0;

/// A stable linear model with poles r·e^{±jθ}, numerator b, delay nk and a non-trivial scaling.
inline models::LinearModel resonant_linear(double r, double theta, Eigen::VectorXd b, int nk,
                                           models::Scaling scaling = {}) {
  models::LinearModel m;
  Eigen::VectorXcd poles(2);
  poles << std::polar(r, theta), std::polar(r, -theta);
  m.tf.a = models::polynomial_from_roots(poles).tail(2);
  m.tf.b = std::move(b);
  m.tf.nk = nk;
  m.fs = kFs;
  m.scaling = scaling;
  return m;
}

/// A pure gain as a linear model: B(q) = gain, A(q) = 1.
inline models::LinearModel gain_model(double gain) {
  models::LinearModel m;
  m.tf.b = Eigen::VectorXd::Constant(1, gain);
  m.fs = kFs;
  return m;
}

/// A 4th-order linear model with delay and scaling, as an identification would store it.
inline models::LinearModel example_linear() {
  models::LinearModel m;
  Eigen::VectorXcd poles(4);
  poles << std::polar(0.95, 0.2), std::polar(0.95, -0.2), std::polar(0.8, 1.0), std::polar(0.8, -1.0);
  m.tf.a = models::polynomial_from_roots(poles).tail(4);
  m.tf.b = Eigen::Vector3d(0.03, -0.01, 0.02);
  m.tf.nk = 2;
  m.fs = kFs;
  m.scaling = {0.01, 0.8, -0.02, 1.1};
  return m;
}

/// A NARX model (na = 4, nb = 3, nk = 1, 6 tanh nodes) with random weights from `seed`; `y_scale`
/// sets its raw output level (its scaled output stays within about ±0.15).
inline models::NarxModel example_narx(std::uint64_t seed, double y_scale = 0.7) {
  models::NarxStructure st;
  st.na = 4;
  st.nb = 3;
  st.nk = 1;
  st.hidden = {6};
  models::NarxModel m = models::NarxModel::with_structure(st, {0.0, 1.2, 0.01, y_scale}, kFs);
  m.net.initialize(1.0, seed);
  return m;
}

/// A neural feedback controller of `structure` on example_narx(plant_seed), its weights drawn from
/// `seed` with output scale `output_scale`.
inline models::NeuralFeedback example_feedback(const models::FeedbackStructure& structure, std::uint64_t plant_seed,
                                               std::uint64_t seed, double output_scale) {
  models::NeuralFeedback c = models::NeuralFeedback::with_structure(structure, example_narx(plant_seed));
  models::initialize_feedback(c, seed, output_scale);
  return c;
}

/// An LQ feedforward controller on example_linear() with input weight `R` (output weight 20): what a chain's
/// feedforward slot runs.
inline models::LqFeedforward example_lq(double R = 1e-3) { return models::design_lq(example_linear(), {R, 20.0}); }

/// The neural feedback controller the chain tests run in the feedback slot: lags 2, 2, 3, five hidden nodes, on
/// example_narx(41) (its weights from seed 9, output scale 0.3).
inline models::NeuralFeedback chain_feedback() {
  models::FeedbackStructure s;
  s.nu = 2;
  s.nv = 2;
  s.ny = 3;
  s.hidden = {5};
  return example_feedback(s, 41, 9, 0.3);
}

/// `n` samples uniform in ±amplitude from dsp::Rng(seed).
inline Eigen::VectorXd uniform(Eigen::Index n, double amplitude, std::uint64_t seed) {
  dsp::Rng rng(seed);
  Eigen::VectorXd x(n);
  for (Eigen::Index k = 0; k < n; ++k) x[k] = rng.uniform(-amplitude, amplitude);
  return x;
}

/// The largest |x(k) − x(k−1)| of `x`.
inline double largest_step(const Eigen::VectorXd& x) {
  double step = 0.0;
  for (Eigen::Index k = 1; k < x.size(); ++k) step = std::max(step, std::abs(x[k] - x[k - 1]));
  return step;
}

/// The safety limiter's curve written out independently of the engine: identity up to the knee,
/// then knee + (1 − knee)·tanh((|v| − knee)/(1 − knee)) with the sign of v.
inline double reference_soft_limit(double v, double knee) {
  if (std::abs(v) <= knee) return v;
  const double s = v < 0 ? -1.0 : 1.0;
  return s * (knee + (1.0 - knee) * std::tanh((std::abs(v) - knee) / (1.0 - knee)));
}

}  // namespace panelbass::engine::testing

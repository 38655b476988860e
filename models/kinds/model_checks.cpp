#include "models/kinds/model_checks.h"

#include <cmath>
#include <cstdint>
#include <numbers>

#include "dsp/random.h"
#include "models/linear/extended_precision.h"

namespace panelbass::models {
namespace {

// The seed of the free run's noise (the NARX loader's).
constexpr std::uint64_t kFreeRunSeed = 20240501;

}  // namespace

std::optional<UnstablePole> unstable_pole(const TransferFunction& tf, double fs) {
  const Eigen::VectorXcd poles = tf.poles();
  Eigen::Index worst = -1;
  for (Eigen::Index i = 0; i < poles.size(); ++i) {
    if (worst < 0 || std::abs(poles[i]) > std::abs(poles[worst])) worst = i;
  }
  if (worst < 0 || std::abs(poles[worst]) < 1.0) return std::nullopt;
  return UnstablePole{std::abs(poles[worst]), std::abs(std::arg(poles[worst])) * fs / (2.0 * std::numbers::pi)};
}

std::optional<double> unstable_lq_radius(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, const Eigen::VectorXd& L) {
  const Eigen::MatrixXd loop = A - B * L.transpose();
  const double radius = static_cast<double>(extended::spectral_radius(loop.cast<extended::Real>()));
  if (radius < 1.0) return std::nullopt;
  return radius;
}

Eigen::VectorXd free_run_drive() {
  dsp::Rng rng(kFreeRunSeed);
  Eigen::VectorXd u(kFreeRunSamples);
  for (Eigen::Index k = 0; k < u.size(); ++k) u[k] = rng.uniform(-1.0, 1.0);
  return u;
}

std::optional<Runaway> runaway(const Eigen::VectorXd& y_scaled) {
  for (Eigen::Index k = 0; k < y_scaled.size(); ++k) {
    if (!(std::abs(y_scaled[k]) <= kFreeRunBound)) return Runaway{k + 1, std::abs(y_scaled[k])};
  }
  return std::nullopt;
}

std::optional<Runaway> free_run_runaway(const NarxModel& m) { return runaway(m.simulate_scaled(free_run_drive())); }

std::optional<Runaway> closed_loop_runaway(const NeuralFeedback& c) {
  const ClosedLoopRun run = simulate_closed_loop(c, free_run_drive());
  return runaway(c.plant.scaling.scale_y(run.y));
}

}  // namespace panelbass::models

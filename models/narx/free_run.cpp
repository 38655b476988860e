#include "models/narx/free_run.h"

#include <cmath>
#include <cstdint>

#include "dsp/random.h"

namespace panelbass::models {
namespace {

// The seed of the free run's noise.
constexpr std::uint64_t kFreeRunSeed = 20240501;

}  // namespace

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

}  // namespace panelbass::models

#pragma once
// Seeded white noise for tests: the independent input and disturbance of an estimator's or a spectrum's test.

#include <Eigen/Core>
#include <cstdint>

#include "dsp/random.h"

namespace panelbass::testing_support {

/// n samples of white Gaussian noise of standard deviation `sigma`, from dsp::Rng(seed).
inline Eigen::VectorXd gaussian(Eigen::Index n, double sigma, std::uint64_t seed) {
  dsp::Rng rng(seed);
  Eigen::VectorXd x(n);
  for (Eigen::Index i = 0; i < n; ++i) x[i] = sigma * rng.gaussian();
  return x;
}

/// n samples of white noise uniform in ±amplitude, from dsp::Rng(seed).
inline Eigen::VectorXd uniform_noise(Eigen::Index n, double amplitude, std::uint64_t seed) {
  dsp::Rng rng(seed);
  Eigen::VectorXd x(n);
  for (Eigen::Index i = 0; i < n; ++i) x[i] = rng.uniform(-amplitude, amplitude);
  return x;
}

}  // namespace panelbass::testing_support

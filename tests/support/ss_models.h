#pragma once
// Small neural state-space models written by hand: a lightly damped resonance with a cubic spring term.

#include <cmath>
#include <cstdint>
#include <numbers>

#include "dsp/random.h"
#include "models/state_space_nn/ss_model.h"

namespace panelbass::testing_support {

/// Two states: x(k+1) = r·R(ω)·x + [b; 0]·u − cubic·[x₀³; 0] (+ f), y = [0, 1]·x + d·u (+ h), ω = 2π·f0/fs,
/// r = 0.97 (a lightly damped resonance at f0 Hz), lags 2, an affine encoder whose rest state is `rest`
/// ([c2] = [rest, −rest]). With `network` > 0 the tanh layer (3 nodes, reading x and u) is drawn uniform in
/// ±network (seeded), so f and h have a nonzero nonlinear part besides the cubic. With `cubic_on_input` the
/// cubic is of the drive instead, −cubic·[u³; 0] (a force that saturates before the resonance), and ζ's
/// monomials are of [x; u].
inline models::SsModel resonant_ss(double f0, double fs, double b, double d, double cubic, double network,
                                   double rest, const models::Scaling& scaling, std::uint64_t seed,
                                   bool cubic_on_input = false) {
  models::SsStructure s;
  s.states = 2;
  s.hidden = 3;
  s.lags = 2;
  s.encoder_hidden = 0;
  s.poly_degree = 3;
  s.poly_input = cubic_on_input;  // ζ: the monomials of the two states (and u), degree 2 and 3
  models::SsModel m;
  m.structure = s;
  m.scaling = scaling;
  m.fs = fs;
  m.theta = Eigen::VectorXd::Zero(s.parameter_count());
  auto p = models::ss_parts(s, m.theta.data());
  const double w = 2.0 * std::numbers::pi * f0 / fs, r = 0.97;
  p.A << r * std::cos(w), -r * std::sin(w), r * std::sin(w), r * std::cos(w);
  p.B << b, 0.0;
  p.C << 0.0, 1.0;
  p.D(0, 0) = d;
  // ζ's monomials, degree by degree: x0², x0·x1, x1², x0³, … — x0³ is the fourth; of [x; u], u³ is the last
  p.P(0, cubic_on_input ? p.P.cols() - 1 : 3) = -cubic;
  p.c2 << rest, -rest;
  dsp::Rng rng(seed);
  for (Eigen::Index i = 0; i < p.W1.size(); ++i) p.W1.data()[i] = rng.uniform(-1.0, 1.0);
  for (Eigen::Index i = 0; i < p.b1.size(); ++i) p.b1.data()[i] = rng.uniform(-0.5, 0.5);
  for (Eigen::Index i = 0; i < p.W2.size(); ++i) p.W2.data()[i] = network * rng.uniform(-1.0, 1.0);
  for (Eigen::Index i = 0; i < p.b2.size(); ++i) p.b2.data()[i] = network * rng.uniform(-0.1, 0.1);
  return m;
}

}  // namespace panelbass::testing_support

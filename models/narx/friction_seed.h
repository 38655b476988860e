#pragma once
// Physics-informed initial weights for a NARX network: hidden units seeded as the Coulomb-friction force
// tanh(g·v̂(k)) of an exciter, v̂ the velocity estimated from the regressor (docs/transducer.md, friction).

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <vector>

#include "models/narx/narx_model.h"

namespace panelbass::models {

/// What seed_friction_units found.
struct FrictionSeed {
  Eigen::MatrixXd directions;  ///< column d: c_d with v̂(k−d) ≈ c_d·x(k) + b_d, v̂ in units of its own rms
  Eigen::VectorXd biases;      ///< b_d
  double r_squared = 0.0;      ///< the worst share of v̂(k−d)'s variance the regressor reproduces, over d
  std::vector<double> gains;   ///< g of each seeded node
  int lags = 1;                ///< velocities v̂(k), …, v̂(k−lags+1)
};

/// Seeds the first hidden units of `model.net` (already initialised) with the friction regressor of
/// scaled data u, y: the velocity estimate v̂ = leaky ∫y (the output is an acceleration; its mean removed),
/// normalised to unit rms, is fitted by least squares as c·x(k) + b over the NARX regressor x(k) (the
/// velocity is a state of the plant, so the past outputs and inputs determine it), and hidden unit i gets
/// input weights gains[i]·c and bias gains[i]·b, so that its output is tanh(gᵢ·v̂(k)): a sign-of-velocity
/// force whose sharpness g the training then adjusts. With `lags` > 1 the same for the earlier velocities
/// v̂(k−1) … v̂(k−lags+1) (the force reaches the measured output through the sensor's filter and the panel,
/// so its recent past matters too): node d·gains.size() + i is tanh(gᵢ·v̂(k−d)). The output weights stay as
/// initialised. Throws std::invalid_argument for mismatched or non-finite data, more nodes than the first
/// layer has, a gain that is not finite and > 0, lags < 1, or data too short for the structure.
FrictionSeed seed_friction_units(NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                 const std::vector<double>& gains, int lags = 1);

/// {"gains", "lags", "velocity_fit_r2"}: what a model's meta and an identification's report say of the seed.
nlohmann::json friction_seed_report(const FrictionSeed& seed);

}  // namespace panelbass::models

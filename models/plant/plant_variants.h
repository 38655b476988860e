#pragma once
// Variants of a plant for robustness tests (issue 56's "±20 % variants moved in mixed directions"): the same
// structure with its motor, suspension, coil and friction moved away from the values a design came from.

#include <cstdint>

#include "models/plant/plant_config.h"

namespace panelbass::models {

/// The factors a variant applied to Bl₀, K₀, Le₀ and the friction force Fc (each 1 ± fraction).
struct VariantFactors {
  double force_factor = 1.0;
  double stiffness = 1.0;
  double inductance = 1.0;
  double friction = 1.0;
};

/// Factors 1 ± `fraction` for Bl, K, Le and friction with signs drawn from `seed`, never all alike (mixed
/// directions: when the draw makes them alike, one of them, also drawn, is turned round). Throws
/// std::invalid_argument for a fraction outside (0, 0.9].
VariantFactors variant_factors(double fraction, std::uint64_t seed);

/// `plant` with Bl₀, K₀, Le₀ and the Coulomb force multiplied by `factors`, oversample raised where the faster
/// dynamics need it, and a name that says what moved ("panel-exciter~Bl+20%,K-20%,Le+20%,friction-20%").
PlantConfig varied_plant(const PlantConfig& plant, const VariantFactors& factors);

/// varied_plant with variant_factors(fraction, seed).
PlantConfig varied_plant(const PlantConfig& plant, double fraction, std::uint64_t seed);

}  // namespace panelbass::models

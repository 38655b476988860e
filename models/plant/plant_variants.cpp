#include "models/plant/plant_variants.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/random.h"

namespace panelbass::models {
namespace {

// "+20%" for 1.2, "-20%" for 0.8 (whole percent, as a name should read).
std::string percent(double factor) {
  const long pct = std::lround(100.0 * (factor - 1.0));
  return (pct >= 0 ? "+" : "") + std::to_string(pct) + "%";
}

}  // namespace

VariantFactors variant_factors(double fraction, std::uint64_t seed) {
  if (!(fraction > 0.0 && fraction <= 0.9))
    throw std::invalid_argument("plant variant: the fraction must be within (0, 0.9], got " + std::to_string(fraction));
  dsp::Rng rng(seed);
  std::array<int, 4> sign{};
  for (int& s : sign) s = rng.below(2) == 0 ? -1 : 1;
  if (std::all_of(sign.begin(), sign.end(), [&](int s) { return s == sign[0]; })) sign[rng.below(4)] *= -1;
  return {1.0 + sign[0] * fraction, 1.0 + sign[1] * fraction, 1.0 + sign[2] * fraction, 1.0 + sign[3] * fraction};
}

PlantConfig varied_plant(const PlantConfig& plant, const VariantFactors& f) {
  PlantConfig v = plant;
  v.Bl_Tm *= f.force_factor;
  v.stiffness_N_per_m *= f.stiffness;
  v.Le_H *= f.inductance;
  v.nonlinear.friction.coulomb_N *= f.friction;
  v.oversample = std::max(v.oversample, required_oversample(v));
  v.name = plant.name + "~Bl" + percent(f.force_factor) + ",K" + percent(f.stiffness) + ",Le" + percent(f.inductance) +
           ",friction" + percent(f.friction);
  return v;
}

PlantConfig varied_plant(const PlantConfig& plant, double fraction, std::uint64_t seed) {
  return varied_plant(plant, variant_factors(fraction, seed));
}

}  // namespace panelbass::models

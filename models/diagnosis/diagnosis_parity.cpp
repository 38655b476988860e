#include "models/diagnosis/diagnosis_parity.h"

#include <cmath>

namespace panelbass::models::diagnosis_detail {

DistortionParity distortion_parity(const Candidate& c) {
  switch (c.effect) {
    case Effect::cubic_stiffness:      // x³
    case Effect::force_factor:         // x²·u, x²·v
    case Effect::hysteresis:           // sign of the motion: odd
    case Effect::nonlinear_damping:    // v³
    case Effect::thermal_compression:  // the drive times its (even) power
      return DistortionParity::odd;
    case Effect::asymmetric_stiffness:     // x²
    case Effect::asymmetric_force_factor:  // x·u, x·v
      return DistortionParity::even;
    case Effect::saturation:
      return c.parameters_json.value("one_sided", false) ? DistortionParity::both : DistortionParity::odd;
    case Effect::static_nonlinearity:  // a two-sided knee is odd; one side alone or a polynomial with z² both
      return c.parameters_json.value("shape", "") != "polynomial" && !c.parameters_json.value("one_sided", true)
                 ? DistortionParity::odd
                 : DistortionParity::both;
    case Effect::inductance:  // z·Δu and u²
      return DistortionParity::both;
    case Effect::creep:  // linear: no harmonics
    case Effect::resonance:
    case Effect::antiresonance:
    case Effect::delay:
    case Effect::dc_offset:
      return DistortionParity::none;
  }
  return DistortionParity::both;
}

std::string ruled_out_by_periodic_distortion(const Candidate& c, const PeriodicDistortion& residual) {
  if (!residual.periodic || !residual.odd_lines_only || std::isnan(residual.residual_odd_db) ||
      std::isnan(residual.residual_even_db))
    return "";
  const bool odd_seen = residual.residual_odd_db > residual.threshold_db;
  const bool even_seen = residual.residual_even_db > residual.threshold_db;
  const DistortionParity parity = distortion_parity(c);
  if (parity == DistortionParity::even && odd_seen && !even_seen)
    return "the residual shows odd distortion (" + fixed(residual.residual_odd_db, 1) + " dB over its noise at the empty odd lines) "
           "but none at the empty even lines (" + fixed(residual.residual_even_db, 1) + " dB): an even-order term cannot be what is missing";
  if (parity == DistortionParity::odd && even_seen && !odd_seen)
    return "the residual shows even distortion (" + fixed(residual.residual_even_db, 1) + " dB over its noise at the empty even lines) "
           "but none at the empty odd lines (" + fixed(residual.residual_odd_db, 1) + " dB): an odd-order term cannot be what is missing";
  return "";
}

}  // namespace panelbass::models::diagnosis_detail

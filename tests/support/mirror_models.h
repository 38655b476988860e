#pragma once
// Mirror-filter models written by hand from a plant's physics, shared by the mirror filter's and its
// observer's tests.

#include <cstddef>
#include <cstdint>

#include "dsp/excitation.h"
#include "models/control/mirror_filter.h"

namespace panelbass::testing_support {

/// panel-exciter's physics written in [M1]–[M3]'s units (drive, A, mm, mm/s): amplifier gain G = 20 V, Re = 4 Ω,
/// Le = 0.3 mH, m = 10 g, K0 = 8880 N/m, Rm = 0.4 Ns/m, Bl0 = 1.5 Tm, K(x) = K0(1 + 0.03x + 0.06x²),
/// Bl(x) = Bl0(1 − 0.45x²), Le(x, i) = Le0(1 − 0.1x − 0.02i²), Coulomb friction 0.05 N at 50 mm/s.
inline models::MirrorModel panel_exciter_mirror_model() {
  const double g = 20.0, re = 4.0, le = 3e-4, m = 0.01, k0 = 8880.0, rm = 0.4, bl = 1.5;
  models::MirrorModel model;
  model.fs = 3000.0;
  const double e5 = bl / g / 1000.0;  // V per mm/s over the gain
  model.electrical = {le / g, le / g * -0.1, 0.0, le / g * -0.02, re / g, e5, 0.0, e5 * -0.45, le * -0.1 / g, 0.0};
  const double c0 = 1000.0 * bl / m, c6 = -k0 / m;
  // reluctance force ½·i²·dLe/dx over the mass, in mm/s²: ½·Le0·l1 [H/mm]·1000 [mm/m]·1000 / m
  const double c3 = 0.5 * le * -0.1 * 1000.0 * 1000.0 / m;
  model.mechanical = {c0, 0.0, c0 * -0.45, c3, 0.0, -rm / m, c6, c6 * 0.03, c6 * 0.06, -1000.0 * 0.05 / m};
  model.friction_velocity = 50.0;
  return model;
}

/// The identification drive the mirror tests fit from: a 10–300 Hz multisine at peak 0.5, `n` samples, phases from `seed`.
inline Eigen::VectorXd mirror_test_drive(std::size_t n, std::uint64_t seed) {
  dsp::MultisineSpec spec;
  spec.period = n;
  spec.f_min = 10.0;
  spec.f_max = 300.0;
  spec.amplitude = 0.5;
  spec.seed = seed;
  return dsp::multisine(spec).signal;
}

}  // namespace panelbass::testing_support

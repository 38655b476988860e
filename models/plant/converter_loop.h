#pragma once
// The virtual transducer's converters alone, as a loopback from its DA output to its AD input would hear
// them: the converters' delay, the DA's zero-order hold and reconstruction filter, the AD's anti-alias
// filter, sampled at the end of each sample period as the plant samples its sensor. The identification
// of the process alone (the thesis's fig. 3.6, §4) takes this as its input on the virtual backend, as it
// takes the loopback channel on a sound card.
//
// Both filters are analog Butterworth low-passes (dsp::analog_butterworth_lowpass): their cascade is one
// linear system, so its response to a drive held over each sample is exactly its zero-order-hold
// discretisation, x(k+1) = Ad·x(k) + Bd·u(k) with [Ad Bd; 0 1] = exp([A B; 0 0]·T).

#include <Eigen/Core>
#include <vector>

#include "dsp/butterworth.h"
#include "models/plant/plant_config.h"

namespace panelbass::models {

/// One analog Butterworth section of a converter filter and where its states sit in a state vector:
/// ω/(s+ω) (one state, its output) or ω²/(s² + (ω/q)s + ω²) (two: its output and the output's derivative).
struct ConverterSection : dsp::AnalogSection {
  int state = 0;  ///< index of its first state
};

/// The sections of `filter` (none for order 0), their states laid out from `next` on; `next` is moved past
/// them. Throws std::invalid_argument for an order or cutoff out of range.
std::vector<ConverterSection> converter_sections(const AnalogFilter& filter, int& next);

/// The cascade's equations, the one description of the converters' filters (the virtual transducer integrates
/// them; converters_alone discretises them exactly): each section fed by the previous one's output, ω/(s+ω)
/// as x' = ω(in − x), ω²/(s² + (ω/q)s + ω²) as x1' = x2, x2' = ω²(in − x1) − (ω/q)·x2. Writes the sections'
/// derivatives into `ds` (at their own states) from the state `s` and the cascade's input `in`; returns its
/// output (the last section's x, or `in` when there is no section).
double converter_derivatives(const std::vector<ConverterSection>& sections, const Eigen::VectorXd& s, double in,
                             Eigen::VectorXd& ds) noexcept;

/// `drive` through `plant`'s converters alone (its mechanics and sensor left out), from rest. Throws
/// std::invalid_argument for a non-finite drive sample.
Eigen::VectorXd converters_alone(const PlantConfig& plant, const Eigen::VectorXd& drive);

}  // namespace panelbass::models

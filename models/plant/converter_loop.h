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

#include "models/plant/plant_config.h"

namespace panelbass::models {

/// `drive` through `plant`'s converters alone (its mechanics and sensor left out), from rest. Throws
/// std::invalid_argument for a non-finite drive sample.
Eigen::VectorXd converters_alone(const PlantConfig& plant, const Eigen::VectorXd& drive);

}  // namespace panelbass::models

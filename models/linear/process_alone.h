#pragma once
// The process alone (the thesis's fig. 3.6, §4): a linear model from the drive as the converters delivered it
// (the loopback channel l) to the sensor y, the converters left out.

#include <Eigen/Core>

#include "models/linear/linear_identification.h"

namespace panelbass::models {

/// Samples the sensor is taken earlier than the loopback in the process-alone fit: l(k) → y(k − lag); the model
/// carries this much more delay than the process (its magnitude the process's).
inline constexpr Eigen::Index kProcessAloneLagSamples = 4;

/// A loopback and sensor pair, lagged for the process-alone fit.
struct LoopbackPair {
  Eigen::VectorXd l;  ///< the loopback, its first kProcessAloneLagSamples samples dropped
  Eigen::VectorXd y;  ///< the sensor, its last kProcessAloneLagSamples samples dropped
};

/// The pair (l(k), y(k − kProcessAloneLagSamples)) of a record; an empty record stays empty.
LoopbackPair process_alone_pair(const Eigen::VectorXd& l, const Eigen::VectorXd& y);

/// Identifies the process alone from a lagged estimation pair (and validation pair, possibly empty) with a low-end
/// weighting (one leaky integrator at fs/60 on both signals); the model's offsets and J are those of the pairs
/// themselves, unweighted.
LinearIdentification identify_process_alone(const LoopbackPair& est, const LoopbackPair& val,
                                            const LinearIdentificationSpec& spec);

}  // namespace panelbass::models

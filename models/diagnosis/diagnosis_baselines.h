#pragma once
// The simulations `diagnose` takes that are not linear models: a NARX model, a neural state-space model, a
// diagnosed gray-box model and a virtual-transducer plant.

#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/gray_box_model.h"
#include "models/narx/narx_model.h"
#include "models/plant/plant_config.h"
#include "models/state_space_nn/ss_model.h"

namespace panelbass::models {

/// A NARX model's free-run simulation (its state set by the measured outputs it is given) as a baseline.
SimulationBaseline narx_baseline(const NarxModel& narx);

/// A neural state-space model's free run (its encoder reads the measured outputs it is given) as a baseline.
SimulationBaseline ss_baseline(const SsModel& ss);

/// A diagnosed model (`diagnose --model-out`, kind gray_box) run as it was diagnosed: its linear part and
/// gray-box terms.
SimulationBaseline gray_box_baseline(const GrayBoxModel& model);

/// A virtual-transducer plant run from rest without sensor noise (what it would record, noiselessly).
SimulationBaseline plant_baseline(PlantConfig plant);

}  // namespace panelbass::models

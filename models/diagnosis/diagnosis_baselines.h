#pragma once
// The simulations `diagnose` takes that are not linear models: a model of another kind (NARX, neural
// state-space, a diagnosed gray-box model, an oscillator) and a virtual-transducer plant.

#include <string>
#include <utility>

#include "models/diagnosis/diagnosis.h"
#include "models/plant/plant_config.h"

namespace panelbass::models {

/// A model's free-run simulation as a baseline, its state set by the measured outputs it is given, for any
/// kind with `fs` and `simulate(u, y, init)` (a gray-box model runs as it was diagnosed: its linear part and
/// terms); `kind` names it in the report.
template <class Model>
SimulationBaseline model_baseline(std::string kind, const Model& model) {
  return {std::move(kind), model.fs,
          [model](const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) { return model.simulate(u, y, init); }};
}

/// A virtual-transducer plant run from rest without sensor noise (what it would record, noiselessly).
SimulationBaseline plant_baseline(PlantConfig plant);

}  // namespace panelbass::models

#include "models/diagnosis/diagnosis_baselines.h"

#include "models/plant/virtual_transducer.h"

namespace panelbass::models {

SimulationBaseline plant_baseline(PlantConfig plant) {
  plant.sensor.noise_rms_V = 0.0;
  return {"plant", plant.fs,
          [plant](const Eigen::VectorXd& u, const Eigen::VectorXd&, Eigen::Index) { return simulate(plant, u, 0).y; }};
}

}  // namespace panelbass::models

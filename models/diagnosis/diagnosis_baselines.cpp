#include "models/diagnosis/diagnosis_baselines.h"

#include "models/plant/virtual_transducer.h"

namespace panelbass::models {

SimulationBaseline narx_baseline(const NarxModel& narx) {
  return {"narx", narx.fs,
          [narx](const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) { return narx.simulate(u, y, init); }};
}

SimulationBaseline ss_baseline(const SsModel& ss) {
  return {"ss", ss.fs,
          [ss](const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) { return ss.simulate(u, y, init); }};
}

SimulationBaseline gray_box_baseline(const GrayBoxModel& model) {
  return {"gray_box", model.fs,
          [model](const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) { return model.simulate(u, y, init); }};
}

SimulationBaseline plant_baseline(PlantConfig plant) {
  plant.sensor.noise_rms_V = 0.0;
  return {"plant", plant.fs,
          [plant](const Eigen::VectorXd& u, const Eigen::VectorXd&, Eigen::Index) { return simulate(plant, u, 0).y; }};
}

}  // namespace panelbass::models

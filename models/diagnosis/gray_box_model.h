#pragma once
// The diagnosed model as a model file (issue #35, item 5): the linear baseline and the gray-box terms the
// diagnosis added, {"format":"panelbass.model/1","kind":"gray_box","fs","linear":{a linear model file},
// "terms":[…],"lags","state_mean","state_rms","meta"}. Its simulation is the diagnosis's own
// (simulate_augmented), so a validation of the written file gives the diagnosis's J.

#include <filesystem>
#include <nlohmann/json.hpp>

#include "models/diagnosis/diagnosis.h"

namespace panelbass::models {

/// A linear model with gray-box terms (what a diagnosis of a linear baseline ends with).
struct GrayBoxModel {
  AugmentedModel augmented;  ///< its simulate_baseline is empty: the linear part is the whole baseline
  double fs = 0.0;           ///< sample rate, Hz (that of the linear part)
  nlohmann::json meta = nlohmann::json::object();  ///< provenance: the diagnosis's findings and J

  /// Free-run simulation on raw data (the diagnosis's simulate_augmented); the first `init` measured
  /// outputs set the linear part's state.
  Eigen::VectorXd simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y = {}, Eigen::Index init = 0) const;
  /// One-step prediction: the linear part's one-step prediction plus what the terms add to the simulation
  /// from rest (the terms act on simulated states, not on measured outputs).
  Eigen::VectorXd predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const;
};

/// The final model of `d` as a gray-box model. Throws std::invalid_argument when the diagnosis started from a
/// simulation that is not a linear model (a NARX, ss or plant baseline: its terms need that simulation).
GrayBoxModel gray_box_model_of(const Diagnosis& d);

/// The model file object of `m`.
nlohmann::json gray_box_model_to_json(const GrayBoxModel& m);

/// Reads and validates a "gray_box" model file object: header, its linear part (stable), every term's
/// names and coefficient count; ConfigError names the key ("model.terms[1].effect: unknown …").
GrayBoxModel gray_box_model_from_json(const nlohmann::json& j);

/// One term as JSON (effect, state, threshold, time constant, sidedness, position, shape, filters,
/// coefficients): the model file's and the report's.
nlohmann::json term_to_json(const DiagnosisTerm& t);

}  // namespace panelbass::models

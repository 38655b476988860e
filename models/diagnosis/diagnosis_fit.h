#pragma once
// Diagnosis, the fit every candidate shares: the records, an augmented model's gray-box terms fitted by least
// squares on the estimation residual (and refined on the augmented output's states), a linear refit by OE,
// and a fitted candidate. Folder-internal (namespace diagnosis_detail).

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis.h"

namespace panelbass::models::diagnosis_detail {

/// The records a diagnosis fits on and judges by, and the simulation it starts from.
struct Records {
  const Eigen::VectorXd& u_est;
  const Eigen::VectorXd& y_est;
  const Eigen::VectorXd& u_val;
  const Eigen::VectorXd& y_val;
  double fs;
  Eigen::Index init;
  int lags;
  const AugmentedModel* base = nullptr;  ///< the simulation diagnosed (its linear part and, if not linear, its simulation)
  OutputQuantity output = OutputQuantity::unknown;  ///< what the output measures (which proxy is the displacement)
};

/// An augmented model with its coefficients fitted, and its simulation J on both records.
struct Fit {
  AugmentedModel model;
  double j_est = 0.0;
  double j_val = 0.0;
};

/// One candidate augmentation, fitted.
struct Candidate {
  Effect effect = Effect::dc_offset;
  std::string variant;
  int parameters = 0;
  Fit fit;
  nlohmann::json parameters_json = nlohmann::json::object();
};

/// The largest damping ratio of a pole pair that counts as a resonance of its own (a mode of the mechanics; a pair
/// damped more heavily, as a filter's, has no narrow band that an extra mode could be confused with).
inline constexpr double kLightDamping = 0.2;

/// Whether `terms` hold a term of `effect`.
bool has_effect(const std::vector<DiagnosisTerm>& terms, Effect effect);

/// `x` with `digits` decimals, for the variants' names and the explanations.
std::string fixed(double x, int digits);

/// Fits the coefficients of `terms` by least squares on the estimation residual of `linear`'s simulation
/// and simulates the result on both records.
Fit fit_terms(const Records& r, const LinearModel& linear, std::vector<DiagnosisTerm> terms);

/// `base` refitted by OE from `initial` on the estimation record (nothing if the fit fails).
std::optional<LinearModel> refit_linear(const Records& r, const LinearModel& base, const TransferFunction& initial,
                                        int iterations);

}  // namespace panelbass::models::diagnosis_detail

#pragma once
// Diagnosis, the fit every candidate shares: the records, an augmented model's gray-box terms fitted by least
// squares on the estimation residual (and refined on the augmented output's states), a linear refit by OE,
// and a fitted candidate. Folder-internal (namespace diagnosis_detail).

#include <Eigen/Core>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis.h"

namespace panelbass::models::diagnosis_detail {

struct Records;

/// The simulation of `base` with a linear part, without terms, on the two records (raw units): started from the
/// first `init` measured outputs, as J judges, and from rest, where the terms' states come from.
struct BaseOutputs {
  Eigen::VectorXd est, est_rest, val, val_rest;
};

/// The base outputs of the last few linear parts a diagnosis simulated: every candidate of a round simulates
/// the same two records through the same linear part (only a linear refit changes it), so each is simulated
/// once. Valid for one Records (its records and its base).
class BaseOutputCache {
 public:
  /// The base outputs of `linear` (with the records' base simulation, if any) on `r`'s records.
  std::shared_ptr<const BaseOutputs> of(const Records& r, const LinearModel& linear);

 private:
  static constexpr std::size_t kKept = 4;  ///< the round's linear part and the last few refits
  std::vector<std::pair<LinearModel, std::shared_ptr<const BaseOutputs>>> kept_;
};

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
  std::shared_ptr<BaseOutputCache> base_outputs = std::make_shared<BaseOutputCache>();  ///< see BaseOutputCache
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

/// The BIC score of an augmentation with `parameters` more that takes validation J from `j_before` to `j_after` over
/// `n_val` samples: n·ln(J_before/J_after) − k·ln(n); positive when it earns its parameters.
inline double bic_score(double j_before, double j_after, int parameters, double n_val) {
  return n_val * std::log(j_before / j_after) - parameters * std::log(n_val);
}

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

#pragma once
// Diagnosis, step two: the candidate augmentations of a model — each effect's gray-box term (or a linear
// refit: a delay, a pole and zero pair) fitted on the estimation record and judged on the validation record.
// Folder-internal (namespace diagnosis_detail): the driver (diagnosis.cpp) and the explanations use it.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <functional>
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

/// `x` with `digits` decimals, for the variants' names and the explanations.
std::string fixed(double x, int digits);

/// Fits the coefficients of `terms` by least squares on the estimation residual of `linear`'s simulation
/// and simulates the result on both records.
Fit fit_terms(const Records& r, const LinearModel& linear, std::vector<DiagnosisTerm> terms);

/// `base` refitted by OE from `initial` on the estimation record (nothing if the fit fails).
std::optional<LinearModel> refit_linear(const Records& r, const LinearModel& base, const TransferFunction& initial,
                                        int iterations);

/// Every candidate augmentation of `current`, fitted; the best variant of each effect (by its BIC score
/// against `current`) is kept. `where` is the estimation residual's location (its spectral peak seeds the
/// pole and zero pair).
std::vector<Candidate> candidates(const Records& r, const Fit& current, const ResidualLocation& where,
                                  int oe_iterations);

/// The static nonlinearity's candidates, offered to `offer`: the baseline's dynamics split around it
/// (Wiener: all before; Wiener–Hammerstein: some pole groups before, the rest with the zeros after), the best
/// split found with one shape, then its shapes (a knee on both sides or each on its own at five levels, a
/// polynomial of order 3); each with its position, structure and shape (saturating, dead zone, polynomial).
void static_nonlinearity_candidates(const Records& r, const Fit& current, const std::function<void(Candidate)>& offer);

/// Which harmonics an effect's term makes from a multisine: odd, even, both, or none (a linear refit or
/// a constant).
enum class DistortionParity { none, odd, even, both };

/// The parity of the distortion candidate `c` adds (its effect, and for saturation its sidedness).
DistortionParity distortion_parity(const Candidate& c);

/// Whether `c` can be what a periodic record's residual misses: with an odd multisine, a residual that
/// shows distortion at the empty lines of one parity but not the other rules out a term that makes only the
/// other. Empty when it can; otherwise why not, in words.
std::string ruled_out_by_periodic_distortion(const Candidate& c, const PeriodicDistortion& residual);

}  // namespace panelbass::models::diagnosis_detail

#pragma once
// Diagnosis, when to stop (issue 58): the noise floor a diagnosis compares validation J with — from repeated
// periods when the record repeats, else the residual's top band or what no candidate term explains, whichever is
// lower, so that it does not grow with the distortion — with its uncertainty; and the validation test every
// finding passes, its threshold corrected for how many candidates the round tried. Folder-internal
// (namespace diagnosis_detail), used by the driver (diagnosis.cpp).

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "models/diagnosis/diagnosis_fit.h"

namespace panelbass::models::diagnosis_detail {

/// The family-wise level of a round's test: the chance that noise alone lets any of the candidates tried pass.
inline constexpr double kFamilyLevel = 0.01;

/// How many standard uncertainties of the floor validation J may lie below it before nothing is looked for (and
/// within how many above it a finding says it lies within the floor's uncertainty).
inline constexpr double kFloorUncertainties = 1.0;

/// Where a noise floor estimate comes from.
enum class FloorSource {
  repeated_periods,  ///< the output's variation between periods of a repeating input (distortion repeats, noise does not)
  top_band,          ///< the residual's median PSD over the top quarter of the band, taken as white
  no_candidate,      ///< the validation J of every candidate term fitted at once: what no candidate explains
};

/// The source's name ("repeated periods", "the residual's top band", "what no candidate explains").
std::string to_string(FloorSource source);

/// A noise floor: J (percent) of a model that left only noise, and how well it is known.
struct NoiseFloor {
  double pct = 0.0;          ///< the floor, percent of Σy² over the judged samples
  double relative_sd = 0.0;  ///< its standard uncertainty over pct
  FloorSource source = FloorSource::top_band;
};

/// The noise floor of output `y` (judged after `init` samples) from repeated periods of its input `u`: the
/// variance of y about its mean over the periods, per sample, as a share of Σy² after init. Nothing when u does
/// not repeat at least three times after init (the first whole period is left to settle).
std::optional<NoiseFloor> periodic_noise_floor(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init);

/// The upper quantile z of the standard normal: P(Z > z) = p, 0 < p < 1.
double normal_upper_quantile(double p);

/// The upper quantile of Student's t with `dof` degrees of freedom at p (Cornish–Fisher from the normal's).
double student_upper_quantile(double p, double dof);

/// The validation test of an augmentation: both residuals whitened by the spectrum of e_after (the residual with
/// less of the effect in it; its periodogram smoothed over 33 bins), d_k = ẽ_before(k)² − ẽ_after(k)² averaged
/// in batches (100 samples or more, 20 to 100 of them; shorter when 20 of 100 do not fit), and Wilcoxon's signed-rank statistic of the batch means
/// (normal approximation) against the normal's upper kFamilyLevel/`tried` quantile (Bonferroni over the candidates
/// tried).
struct ValidationGain {
  double gain = 0.0;       ///< (Σe_before² − Σe_after²) / Σe_before²: the share of J the augmentation removes
  double z = 0.0;          ///< the signed-rank statistic of the batch means, in standard deviations under no gain
  int batches = 0;         ///< batch means ranked
  int tried = 1;           ///< candidates the round tried (the correction's count)
  double threshold = 0.0;  ///< the z that passes
  bool significant = false;
};

/// Tests the residuals `before` and `after` (the same judged samples) with `tried` candidates tried.
ValidationGain validation_gain(const Eigen::VectorXd& before, const Eigen::VectorXd& after, int tried);

/// The test as the report's JSON.
nlohmann::json validation_gain_to_json(const ValidationGain& g);

/// The noise floor a diagnosis compares J with: from repeated periods when the validation record repeats;
/// otherwise the lower of the top band of the baseline's validation residual (`located_val`; distortion there
/// lifts it) and what every candidate term fitted at once leaves (`no_candidate_pct`, set; noise the terms cannot
/// fit does not lower it; NaN when the periods gave the floor).
NoiseFloor diagnosis_noise_floor(const Records& r, const Fit& baseline, const ResidualLocation& located_val,
                                 double& no_candidate_pct);

/// The floor as the report's JSON, with the estimates it was chosen from.
nlohmann::json noise_floor_to_json(const NoiseFloor& floor, double top_band_pct, double no_candidate_pct);

}  // namespace panelbass::models::diagnosis_detail

#pragma once
// What a record says before any model is fitted (thesis ch. 3, "Data preprocessing"): the scaling,
// whether the input is white, the delay and the impulse length.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>

#include "models/preprocess/scaling.h"

namespace panelbass::models {

/// The preprocessing figures of one estimation record.
struct DataSurvey {
  Scaling scaling;                 ///< offsets and scales that put u and y in [−1, 1] with zero mean
  int delay = 0;                   ///< samples of dead time from input to output (0 unless delay_found)
  bool delay_found = false;        ///< a tap of the impulse estimate's first half stood out of its noise
  int impulse_length = 0;          ///< samples until the response sinks into the noise
  Eigen::Index lags_examined = 0;  ///< lags of the impulse estimate
  double whiteness_max_abs = 0.0;  ///< largest |r_uu(τ)|, τ = 1..whiteness_lags
  double whiteness_band = 0.0;     ///< its 99 % noise band
  double whiteness_outside = 0.0;  ///< fraction of those lags outside the band
  bool input_white = false;        ///< at most 5 % of the lags outside the band (1 % expected)
};

/// Surveys (u, y): scaling from the data, the input's autocorrelation over `whiteness_lags` lags, and
/// delay and impulse length from the least-squares impulse response over min(max_lag, N/2 − 1) lags.
/// Throws std::invalid_argument for constant or non-finite signals, or fewer than 100 samples.
DataSurvey survey_data(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index max_lag = 1000,
                       Eigen::Index whiteness_lags = 25);

/// How `s.delay` was found, a sentence for a result's "nk_source" (the first significant tap, or none
/// standing out and no dead time assumed).
std::string delay_finding(const DataSurvey& s);

/// The survey as JSON.
nlohmann::json data_survey_to_json(const DataSurvey& s);

}  // namespace panelbass::models

#include "models/linear/data_survey.h"

#include <cmath>
#include <stdexcept>

#include "dsp/correlation.h"
#include "models/linear/impulse_estimate.h"

namespace panelbass::models {

DataSurvey survey_data(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index max_lag,
                       Eigen::Index whiteness_lags) {
  if (u.size() != y.size()) throw std::invalid_argument("input and output lengths differ");
  if (u.size() < 100) throw std::invalid_argument("need at least 100 samples, got " + std::to_string(u.size()));
  DataSurvey s;
  s.scaling = scaling_from_data(u, y);
  const Eigen::VectorXd us = s.scaling.scale_u(u);
  const Eigen::VectorXd ys = s.scaling.scale_y(y);

  const Eigen::Index lags = std::min(whiteness_lags, us.size() - 1);
  const Eigen::VectorXd r = dsp::autocorrelation(us, lags);
  s.whiteness_band = dsp::correlation_noise_band(us.size(), 0.99);
  int outside = 0;
  for (Eigen::Index tau = 1; tau <= lags; ++tau) {
    s.whiteness_max_abs = std::max(s.whiteness_max_abs, std::abs(r[tau]));
    if (std::abs(r[tau]) > s.whiteness_band) ++outside;
  }
  s.whiteness_outside = static_cast<double>(outside) / static_cast<double>(lags);
  s.input_white = s.whiteness_outside <= 0.05;

  s.lags_examined = std::min(max_lag, us.size() / 2 - 1);
  const ImpulseEstimate impulse = estimate_impulse(us, ys, s.lags_examined);
  s.delay = impulse.delay;
  s.delay_found = impulse.delay_found;
  s.impulse_length = impulse.length;
  return s;
}

std::string delay_finding(const DataSurvey& s) {
  const std::string lags = std::to_string(s.lags_examined / 2);
  if (s.delay_found) {
    return "estimated from the impulse response's first significant tap (lag " + std::to_string(s.delay) + " of the first " +
           lags + " examined)";
  }
  return "no tap of the impulse response's first " + lags +
         " lags stood out of its noise (a coloured or band-limited input hides it), so no dead time is assumed: nk = 0";
}

nlohmann::json data_survey_to_json(const DataSurvey& s) {
  return {{"scaling", scaling_to_json(s.scaling)},
          {"delay", s.delay},
          {"delay_found", s.delay_found},
          {"impulse_length", s.impulse_length},
          {"lags_examined", s.lags_examined},
          {"input_white", s.input_white},
          {"whiteness_max_abs", s.whiteness_max_abs},
          {"whiteness_band", s.whiteness_band},
          {"whiteness_outside", s.whiteness_outside}};
}

}  // namespace panelbass::models

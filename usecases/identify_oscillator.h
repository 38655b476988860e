#pragma once
// `identify oscillator` / the identify-oscillator job: a continuous-time oscillator with named nonlinear terms,
// fitted by its simulation error in stages (models/oscillator), the stage of the lowest validation J kept; a fit
// that misses the output says so.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/oscillator/oscillator_model.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// Above this simulation J (%) a fit is called out as missing what the output does.
inline constexpr double kUsefulOscillatorJPct = 10.0;

/// What `identify oscillator` is asked.
struct IdentifyOscillatorRequest {
  Eigen::VectorXd u_est, y_est;  ///< estimation record, raw
  Eigen::VectorXd u_val, y_val;  ///< validation record (empty: none; it chooses the stage)
  double fs = 0.0;               ///< Hz
  std::string data_name, val_name;  ///< where the records came from, kept in the model's meta
  std::vector<std::string> terms{"y3"};  ///< freed in this order, one stage each (y2, y3, y_abs_y, v_log_v, …)
  int substeps = 4;        ///< Runge–Kutta steps per sample (1..64)
  int output_taps = 0;     ///< taps of the output filter (0..64), a final stage
  int input_taps = 0;      ///< taps of the input added to the output (0..64)
  int max_iterations = 200;  ///< Levenberg–Marquardt iterations per stage (1..100000)
  long init = 50;          ///< measured samples that set the state before J
  bool delay = true;       ///< fit the input delay
};

/// What `identify oscillator` made.
struct IdentifyOscillatorReport {
  models::OscillatorModel model;      ///< its meta filled in
  nlohmann::json summary;             ///< {"J_est_pct","J_val_pct","chosen_stage","stages","params","seconds"}
  std::vector<std::string> warnings;  ///< a fit that misses says so
};

/// Throws RequestError naming the field for a request out of range (an unknown term included).
void check(const IdentifyOscillatorRequest& request);

/// The request's fields (the records by their names), as the API echoes its params.
nlohmann::json to_json(const IdentifyOscillatorRequest& request);

/// Fits the oscillator.
IdentifyOscillatorReport identify_oscillator(const IdentifyOscillatorRequest& request, Progress& progress);

}  // namespace panelbass::usecases

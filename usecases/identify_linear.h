#pragma once
// `identify linear` / the identify-linear job: a linear model (FIR, ARX, OE, Zhu's method or Backx's FIR-Hankel-OE)
// of one order or the order an order scan picks by validation J ([2A]), with the data survey it was found by; or the
// process alone (the thesis's fig. 3.6, §4), from the drive as the converters delivered it.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/linear/linear_model.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// Highest order (na = nb) a linear request takes.
inline constexpr int kMaxLinearOrder = 200;
/// Most FIR taps a linear request takes (method "fir": the order is the taps).
inline constexpr int kMaxFirTaps = 5000;

/// What `identify linear` is asked.
struct IdentifyLinearRequest {
  Eigen::VectorXd u_est, y_est;  ///< estimation record, raw (with process "alone": the loopback l, not the drive)
  Eigen::VectorXd u_val, y_val;  ///< validation record (empty: none; a scan needs it)
  double fs = 0.0;               ///< Hz
  std::string data_name, val_name;  ///< where the records came from, kept in the model's meta
  /// fir, arx, oe, zhu or backx. OE: on the shared benchmark records and the simulator's it gives the lower
  /// validation J at the default order (docs/identification.md, "identify linear's default method").
  std::string method = "oe";
  int order = 8;              ///< na = nb (FIR: taps), 1..kMaxLinearOrder (FIR 1..kMaxFirTaps)
  int delay = -1;             ///< input delay nk (−1: estimated from the data), −1..100000
  std::vector<int> scan;      ///< {from, to}: scan these orders and keep the one the rule picks (empty: no scan)
  long init = 50;             ///< measured outputs that set the model's state before J, 0..1000000
  int decimation = 1;         ///< backx: decimation factor before the FIR step, 1..64
  int max_iterations = 100;   ///< output-error iterations, 1..100000
  /// "with_converters" (the drive is the input) or "alone" (u_est/u_val are the loopback: the process without the
  /// converters, fitted from l(k) to y(k − models::kProcessAloneLagSamples) and weighted toward the low end).
  std::string process = "with_converters";
};

/// One output-error iteration of the final fit.
struct LinearIteration {
  int iteration = 0;     ///< 1, 2, …
  double j_est_pct = 0;  ///< [2A] from rest on the estimation record (the OE loss over the output's mean square)
};

/// What `identify linear` made.
struct IdentifyLinearReport {
  models::LinearModel model;  ///< its meta filled in
  /// {"method","order","na","nb","J_est_pct","J_val_pct","J_pred_est_pct","delay","nk_source","poles","zeros",
  /// "survey","process"} and with a scan {"scan","order_rule","scan_skipped"}.
  nlohmann::json summary;
  std::vector<LinearIteration> history;  ///< the final fit's output-error iterations (empty for FIR, ARX)
  std::vector<std::string> warnings;     ///< a fit no better than an output of zero, with what to try
};

/// Throws RequestError naming the field for a request out of range or inconsistent; the records' checks (lengths,
/// a scan's validation data) only once there are records (u_est not empty).
void check(const IdentifyLinearRequest& request);

/// Throws RequestError "scan" for a scan not {from, to} with 1 ≤ from ≤ to ≤ the highest order, or, when
/// `validated` is false, for any scan (the order is picked by validation J).
void check_scan(const std::vector<int>& scan, bool validated);

/// The request's fields (the records by their names), as the API echoes its params.
nlohmann::json to_json(const IdentifyLinearRequest& request);

/// Identifies the model.
IdentifyLinearReport identify_linear(const IdentifyLinearRequest& request, Progress& progress);

}  // namespace panelbass::usecases

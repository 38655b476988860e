#pragma once
// Linear identification end to end: preprocessing, the chosen estimator, validation by simulation
// (J, [2A]), and the order scan of thesis fig. 4.8.

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "models/linear/data_survey.h"
#include "models/linear/linear_model.h"
#include "models/linear/oe_estimator.h"

namespace panelbass::models {

/// The estimators.
enum class LinearMethod { fir, arx, oe, zhu, backx };

/// "fir" → LinearMethod::fir, …; throws std::invalid_argument listing the names.
LinearMethod parse_linear_method(const std::string& name);
/// The method's name.
std::string to_string(LinearMethod method);

/// What to identify and how.
struct LinearIdentificationSpec {
  LinearMethod method = LinearMethod::zhu;
  int order = 8;              ///< na = nb = order (FIR: taps)
  int delay = -1;             ///< nk; −1 = the delay estimated from the data
  int scan_from = 0;          ///< with scan_to > 0: scan orders scan_from..scan_to and keep the chosen one
  int scan_to = 0;
  Eigen::Index init = 50;     ///< measured outputs that set the model's state before J is computed
  double fs = 0.0;            ///< sample rate of the data, Hz
  int decimation = 1;         ///< Backx: decimation factor before the FIR step
  OeOptions oe;               ///< OE, Zhu and Backx refinement
  std::function<void(const std::string& stage, double fraction)> progress;  ///< stage and its own fraction
};

/// The fraction of the whole identification done when `stage` ("survey", "scan", "fit") of `spec` reports
/// `fraction` of itself: a scan's orders and the final fit share the run equally, so it never goes back.
double identification_fraction(const LinearIdentificationSpec& spec, const std::string& stage, double fraction);

/// One order of the scan.
struct OrderScanEntry {
  int order = 0;
  double j_est_pct = 0.0;
  double j_val_pct = 0.0;
};

/// What identification produced.
struct LinearIdentification {
  LinearModel model;
  DataSurvey survey;                  ///< of the estimation data
  std::string nk_source;              ///< how nk was found: "given", or delay_finding(survey)
  double j_est_pct = 0.0;             ///< simulation J on the estimation data
  double j_val_pct = std::numeric_limits<double>::quiet_NaN();   ///< on the validation data, if any
  double j_pred_est_pct = 0.0;        ///< one-step prediction J on the estimation data
  std::vector<OrderScanEntry> scan;   ///< empty without a scan
  std::string order_rule;             ///< how the order was chosen
  std::vector<std::string> scan_skipped;  ///< the orders the data could not support, each with why ("order 14:
                                          ///< ARX(...): the input does not excite ..."); not in `scan`
};

/// Identifies a linear model from raw estimation data (and validation data, may be empty). The scaling,
/// delay and survey come from the estimation data only. With a scan, the order kept is the smallest
/// whose validation J is within 5 % of the best (validation data required); an order the data cannot
/// support (an EstimationError: noise-free data of a lower order, too few samples) is skipped and listed
/// in scan_skipped (an error only when every order fails). Throws EstimationError or
/// std::invalid_argument with the reason.
LinearIdentification identify_linear(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est,
                                     const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val,
                                     const LinearIdentificationSpec& spec);

/// Simulation J ([2A], percent) of `model` on raw data: the first `init` measured outputs set the state,
/// J is computed over the samples after them.
double simulation_j_percent(const LinearModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                            Eigen::Index init);

}  // namespace panelbass::models

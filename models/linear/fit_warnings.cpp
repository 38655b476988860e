#include "models/linear/fit_warnings.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "models/linear/linear_identification.h"
#include "models/linear/zhu_estimator.h"
#include "models/preprocess/scaling.h"

namespace panelbass::models {
namespace {

// Output-error iterations of the reference: enough for Zhu's refinement to settle on a record this size.
constexpr int kReferenceIterations = 30;

std::string percent(double j) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g %%", j);
  return text;
}

}  // namespace

double linear_reference_j_pct(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val,
                              const Eigen::VectorXd& y_val, int order, int nk, Eigen::Index init) {
  // Zhu's method directly, without identify_linear's data survey: the delay is given, and the survey's
  // impulse estimate over 1000 lags would cost more than the fit.
  const int n = std::max(order, 1);
  try {
    LinearModel m;
    m.scaling = scaling_from_data(u_est, y_est);
    m.fs = 1.0;  // J does not depend on the rate
    ZhuOptions options;
    options.oe.max_iterations = kReferenceIterations;
    m.tf = estimate_zhu(m.scaling.scale_u(u_est), m.scaling.scale_y(y_est), {n, n, std::max(nk, 0)}, options).tf;
    if (!m.tf.all_finite() || !m.tf.is_stable()) return std::numeric_limits<double>::quiet_NaN();
    const bool validated = u_val.size() > 0;
    return simulation_j_percent(m, validated ? u_val : u_est, validated ? y_val : y_est, init);
  } catch (const std::exception&) {
    return std::numeric_limits<double>::quiet_NaN();  // no linear model of that order: nothing to compare
  }
}

std::vector<std::string> fit_warnings(double j_pct, const std::string& figure, double linear_j_pct,
                                      const std::string& advice) {
  std::vector<std::string> out;
  if (!std::isfinite(j_pct)) {
    out.push_back("The model's " + figure + " is not a number: its simulation diverged. " + advice);
  } else if (j_pct >= 100.0) {
    out.push_back("The model is no better than an output of zero: " + figure + " = " + percent(j_pct) +
                  " (J ≥ 100 %). " + advice);
  }
  if (std::isfinite(j_pct) && std::isfinite(linear_j_pct) && j_pct > linear_j_pct) {
    out.push_back("The model is worse than a linear model of the same order fitted to the same record (Zhu's method): " +
                  figure + " = " + percent(j_pct) + " against " + percent(linear_j_pct) + ". " + advice);
  }
  return out;
}

}  // namespace panelbass::models

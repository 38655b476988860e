#include "models/linear/fit_warnings.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "models/linear/linear_identification.h"

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
  LinearIdentificationSpec spec;
  spec.method = LinearMethod::zhu;
  spec.order = std::max(order, 1);
  spec.delay = std::max(nk, 0);
  spec.init = init;
  spec.fs = 1.0;  // J does not depend on the rate
  spec.oe.max_iterations = kReferenceIterations;
  try {
    const LinearIdentification id = identify_linear(u_est, y_est, u_val, y_val, spec);
    return u_val.size() ? id.j_val_pct : id.j_est_pct;
  } catch (const std::exception&) {
    return std::numeric_limits<double>::quiet_NaN();  // no stable linear model of that order: nothing to compare
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

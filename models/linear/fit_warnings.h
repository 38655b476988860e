#pragma once
// Whether a model is any better than a trivial one: an output of zero (J = 100 %), or a linear model fitted
// to the same record. A fit that is not ends with sentences saying so and what to try, not in silence.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace panelbass::models {

/// The simulation J (percent, [2A]) of a linear model fitted by Zhu's method (na = nb = `order`, delay `nk`,
/// `init` measured outputs setting the state) fitted on the estimation part and judged on the validation
/// part (the estimation part when there is none); NaN when no stable linear model can be fitted.
double linear_reference_j_pct(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val,
                              const Eigen::VectorXd& y_val, int order, int nk, Eigen::Index init);

/// Sentences for a model whose simulation J named `figure` (e.g. "J_val") is `j_pct`: one if J ≥ 100 % (no
/// better than an output of zero), one if J exceeds `linear_j_pct` (a linear model's J on the same part; NaN:
/// not compared); each ends with `advice` (what to try). Empty when all is well.
std::vector<std::string> fit_warnings(double j_pct, const std::string& figure, double linear_j_pct,
                                      const std::string& advice);

}  // namespace panelbass::models

#include "models/validation/performance.h"

#include <stdexcept>
#include <string>

namespace panelbass::models {

double j_percent(const Eigen::VectorXd& y_model, const Eigen::VectorXd& y, Eigen::Index start) {
  if (y_model.size() != y.size()) {
    throw std::invalid_argument("J: model output has " + std::to_string(y_model.size()) +
                                " samples, measured output " + std::to_string(y.size()));
  }
  if (start < 0 || start >= y.size()) throw std::invalid_argument("J: empty range");
  const Eigen::Index n = y.size() - start;
  if (!y_model.tail(n).allFinite()) throw std::invalid_argument("J: model output is not finite");
  const double energy = y.tail(n).squaredNorm();
  if (!(energy > 0.0)) throw std::invalid_argument("J: measured output has no energy");
  // [2A] J = Σ (y_model − y_process)² / Σ y_process²
  return 100.0 * (y_model.tail(n) - y.tail(n)).squaredNorm() / energy;
}

double jc_percent(const Eigen::VectorXd& y, const Eigen::VectorXd& y_desired, Eigen::Index skip,
                  const Eigen::VectorXd& weight) {
  if (y.size() != y_desired.size()) {
    throw std::invalid_argument("jc_percent: y has " + std::to_string(y.size()) + " samples, y_desired " +
                                std::to_string(y_desired.size()));
  }
  if (weight.size() > 0 && weight.size() != y.size()) {
    throw std::invalid_argument("jc_percent: " + std::to_string(weight.size()) + " weights for " +
                                std::to_string(y.size()) + " samples");
  }
  const Eigen::Index n = y.size() - skip;
  if (n <= 0) throw std::invalid_argument("jc_percent: nothing left after the skip of " + std::to_string(skip));
  const Eigen::ArrayXd w = weight.size() > 0 ? Eigen::ArrayXd(weight.tail(n).array()) : Eigen::ArrayXd::Ones(n);
  const double energy = (w * y_desired.tail(n).array().square()).sum();
  if (!(energy > 0.0)) throw std::invalid_argument("jc_percent: the desired output is zero");
  // [2C] J_c = Σ (y_desired − y_system)² / Σ y_desired² (each term times w(k) when weighted)
  return 100.0 * (w * (y_desired.tail(n) - y.tail(n)).array().square()).sum() / energy;
}

}  // namespace panelbass::models

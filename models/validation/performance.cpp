#include "models/validation/performance.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace panelbass::models {

double j_ratio_percent(double error_energy, double output_energy, const std::string& channel) {
  if (!(output_energy > 0.0) || !std::isfinite(output_energy)) {
    throw std::invalid_argument("J: " + channel + " has no energy over the samples judged");
  }
  if (!std::isfinite(error_energy) || error_energy < 0.0) throw std::invalid_argument("J: the error of " + channel + " is not finite");
  // [2A] J = Σ (y_model − y_process)² / Σ y_process²
  return 100.0 * error_energy / output_energy;
}

double j_percent(const Eigen::VectorXd& y_model, const Eigen::VectorXd& y, Eigen::Index start, const std::string& channel) {
  if (y_model.size() != y.size()) {
    throw std::invalid_argument("J: model output has " + std::to_string(y_model.size()) +
                                " samples, measured output " + std::to_string(y.size()));
  }
  if (start < 0 || start >= y.size()) throw std::invalid_argument("J: empty range");
  const Eigen::Index n = y.size() - start;
  if (!y_model.tail(n).allFinite()) throw std::invalid_argument("J: model output is not finite");
  return j_ratio_percent((y_model.tail(n) - y.tail(n)).squaredNorm(), y.tail(n).squaredNorm(), channel);
}

double j_weighted_percent(const Eigen::VectorXd& y_model, const Eigen::VectorXd& y, const Eigen::VectorXd& weight,
                          Eigen::Index start, const std::string& channel) {
  if (y_model.size() != y.size() || weight.size() != y.size()) {
    throw std::invalid_argument("J: model output has " + std::to_string(y_model.size()) + " samples, measured output " +
                                std::to_string(y.size()) + ", weights " + std::to_string(weight.size()));
  }
  if (start < 0 || start >= y.size()) throw std::invalid_argument("J: empty range");
  const Eigen::Index n = y.size() - start;
  if (!y_model.tail(n).allFinite()) throw std::invalid_argument("J: model output is not finite");
  if ((weight.tail(n).array() < 0.0).any()) throw std::invalid_argument("J: a negative weight");
  const Eigen::ArrayXd w = weight.tail(n).array();
  return j_ratio_percent((w * (y_model.tail(n) - y.tail(n)).array().square()).sum(), (w * y.tail(n).array().square()).sum(),
                         channel);
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
  // [2C] J_c = Σ (y_desired − y_system)² / Σ y_desired² (each term times w(k) when weighted)
  return j_ratio_percent((w * (y_desired.tail(n) - y.tail(n)).array().square()).sum(),
                         (w * y_desired.tail(n).array().square()).sum(), "the desired output");
}

}  // namespace panelbass::models

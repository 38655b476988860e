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

}  // namespace panelbass::models

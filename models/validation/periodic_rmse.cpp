#include "models/validation/periodic_rmse.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "models/validation/performance.h"

namespace panelbass::models {

PeriodicScore periodic_score(const std::vector<Eigen::MatrixXd>& simulated, const std::vector<Eigen::MatrixXd>& measured,
                             Eigen::Index period, Eigen::Index init) {
  if (simulated.empty() || simulated.size() != measured.size()) {
    throw std::invalid_argument("periodic score: " + std::to_string(simulated.size()) + " simulated and " +
                                std::to_string(measured.size()) + " measured realisations");
  }
  if (period < 1 || init < 0 || init >= period) {
    throw std::invalid_argument("periodic score: init " + std::to_string(init) + " must be in [0, period " +
                                std::to_string(period) + ")");
  }
  const Eigen::Index p = measured.front().cols(), kept = period - init;
  PeriodicScore score;
  score.rmse = Eigen::VectorXd::Zero(p);
  double error_energy = 0.0, output_energy = 0.0;
  Eigen::Index terms = 0;
  for (std::size_t r = 0; r < measured.size(); ++r) {
    const Eigen::MatrixXd& y = measured[r];
    const Eigen::MatrixXd& s = simulated[r];
    if (s.rows() != y.rows() || s.cols() != p || y.cols() != p || y.rows() % period != 0 || y.rows() == 0) {
      throw std::invalid_argument("periodic score: realisation " + std::to_string(r + 1) + " is " + std::to_string(s.rows()) +
                                  "×" + std::to_string(s.cols()) + " simulated, " + std::to_string(y.rows()) + "×" +
                                  std::to_string(y.cols()) + " measured, not whole periods of " + std::to_string(period));
    }
    if (!s.allFinite()) throw std::invalid_argument("periodic score: the simulation of realisation " + std::to_string(r + 1) + " is not finite");
    for (Eigen::Index q = 0; q < y.rows() / period; ++q) {
      const Eigen::MatrixXd e = s.middleRows(q * period + init, kept) - y.middleRows(q * period + init, kept);
      score.rmse += (e.colwise().squaredNorm() / static_cast<double>(kept)).cwiseSqrt().transpose();
      error_energy += e.squaredNorm();
      output_energy += y.middleRows(q * period + init, kept).squaredNorm();
      ++terms;
    }
  }
  score.rmse /= static_cast<double>(terms);
  score.mean_rmse = score.rmse.mean();
  score.j_pct = j_ratio_percent(error_energy, output_energy, "the measured outputs");
  return score;
}

}  // namespace panelbass::models

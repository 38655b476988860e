#include "models/narx/friction_seed.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/leaky_integral.h"

namespace panelbass::models {
namespace {

void check_inputs(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                  const std::vector<double>& gains, int lags, Eigen::Index first) {
  const std::string where = "seed_friction_units";
  if (u.size() != y.size()) {
    throw std::invalid_argument(where + ": u has " + std::to_string(u.size()) + " samples, y " +
                                std::to_string(y.size()));
  }
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    if (!std::isfinite(u[k]) || !std::isfinite(y[k])) {
      throw std::invalid_argument(where + ": sample " + std::to_string(k) + " is not finite");
    }
  }
  if (lags < 1) throw std::invalid_argument(where + ": lags must be >= 1, got " + std::to_string(lags));
  const std::size_t nodes = gains.size() * static_cast<std::size_t>(lags);
  if (model.net.hidden().empty() || static_cast<std::size_t>(model.net.hidden()[0]) < nodes) {
    throw std::invalid_argument(where + ": " + std::to_string(nodes) + " friction units, but the first hidden layer has " +
                                std::to_string(model.net.hidden().empty() ? 0 : model.net.hidden()[0]) + " nodes");
  }
  for (std::size_t i = 0; i < gains.size(); ++i) {
    if (!(gains[i] > 0.0) || !std::isfinite(gains[i])) {
      throw std::invalid_argument(where + ": gain " + std::to_string(i) + " must be finite and > 0, got " +
                                  std::to_string(gains[i]));
    }
  }
  const Eigen::Index inputs = model.net.inputs();
  if (u.size() - first < 4 * (inputs + 1)) {
    throw std::invalid_argument(where + ": " + std::to_string(u.size()) + " samples are too few for " +
                                std::to_string(inputs) + " regressors");
  }
}

}  // namespace

FrictionSeed seed_friction_units(NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                 const std::vector<double>& gains, int lags) {
  const Eigen::Index first =
      std::max<Eigen::Index>(model.structure.na, model.structure.nk + model.structure.nb) + std::max(0, lags - 1);
  check_inputs(model, u, y, gains, lags, first);
  const Eigen::Index inputs = model.net.inputs();
  const Eigen::Index n = u.size();

  // v̂: the leaky integral of the centred output (an acceleration), itself centred and of unit rms.
  const Eigen::VectorXd centred = y.array() - y.mean();
  if (!(centred.cwiseAbs().maxCoeff() > 1e-12 * std::max(1.0, y.cwiseAbs().maxCoeff()))) {
    throw std::invalid_argument("seed_friction_units: the output is constant: no velocity to fit");
  }
  Eigen::VectorXd velocity = dsp::leaky_integral(centred, model.fs > 0.0 ? model.fs : 1.0);
  velocity.array() -= velocity.tail(n - first).mean();
  const double rms = std::sqrt(velocity.tail(n - first).squaredNorm() / static_cast<double>(n - first));
  if (!(rms > 0.0)) throw std::invalid_argument("seed_friction_units: the output does not move after the regressor's start");
  velocity /= rms;

  // Least squares v̂(k−d) ≈ c_d·x(k) + b_d over the regressor, d = 0 … lags−1, by the normal equations
  // (linear in N; one matrix for every lag).
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(inputs + 1, inputs + 1);
  Eigen::MatrixXd right = Eigen::MatrixXd::Zero(inputs + 1, lags);
  Eigen::VectorXd x(inputs + 1);
  x[inputs] = 1.0;
  for (Eigen::Index k = first; k < n; ++k) {
    model.regressor(u, y, k, x.head(inputs));
    normal.selfadjointView<Eigen::Lower>().rankUpdate(x);
    for (int d = 0; d < lags; ++d) right.col(d) += velocity[k - d] * x;
  }
  const double ridge = 1e-10 * std::max(1.0, normal.diagonal().maxCoeff());
  normal.diagonal().array() += ridge;
  const Eigen::MatrixXd solution = normal.selfadjointView<Eigen::Lower>().ldlt().solve(right);

  Eigen::VectorXd residual = Eigen::VectorXd::Zero(lags), total = Eigen::VectorXd::Zero(lags);
  for (Eigen::Index k = first; k < n; ++k) {
    model.regressor(u, y, k, x.head(inputs));
    for (int d = 0; d < lags; ++d) {
      const double e = velocity[k - d] - solution.col(d).dot(x);
      residual[d] += e * e;
      total[d] += velocity[k - d] * velocity[k - d];
    }
  }
  FrictionSeed seed;
  seed.directions = solution.topRows(inputs);
  seed.biases = solution.row(inputs).transpose();
  seed.r_squared = 1.0 - (residual.array() / total.array()).maxCoeff();
  seed.gains = gains;
  seed.lags = lags;

  // Layer 0 of θ: the weight matrix row by row (row i = node i's input weights), then the biases.
  Eigen::VectorXd& theta = model.net.parameters();
  const Eigen::Index width = model.net.hidden()[0];
  for (int d = 0; d < lags; ++d) {
    for (std::size_t i = 0; i < gains.size(); ++i) {
      const auto node = static_cast<Eigen::Index>(d * gains.size() + i);
      theta.segment(node * inputs, inputs) = gains[i] * seed.directions.col(d);
      theta[width * inputs + node] = gains[i] * seed.biases[d];
    }
  }
  return seed;
}

nlohmann::json friction_seed_report(const FrictionSeed& seed) {
  return {{"gains", seed.gains}, {"lags", seed.lags}, {"velocity_fit_r2", seed.r_squared}};
}

}  // namespace panelbass::models

#include "models/state_space_nn/ss_initial_state.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/NonLinearOptimization>
#include <unsupported/Eigen/NumericalDiff>

namespace panelbass::models {

SsStatePrior ss_state_prior(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) {
  if (u.size() != y.size()) throw std::invalid_argument("ss_state_prior: input and output lengths differ");
  const Eigen::Index n = m.structure.states, skip = init + 2 * m.structure.lags, count = u.size() - skip;
  if (count < n + 2) {
    throw std::invalid_argument("ss_state_prior: " + std::to_string(u.size()) + " samples, at least " +
                                std::to_string(skip + n + 2) + " needed (init, twice the lags and a sample more than the states)");
  }
  const Eigen::VectorXd us = m.scaling.scale_u(u), ys = m.scaling.scale_y(y);
  Eigen::VectorXd z(2 * m.structure.lags);
  ss_regressor(us, ys, init, m.structure.lags, z);
  Eigen::MatrixXd x0(n, 1), encoder_hidden;
  ss_encode(ss_parts(m.structure, m.theta.data()), z, encoder_hidden, x0);
  Eigen::MatrixXd states;
  const Eigen::VectorXd out = m.run_scaled(us, x0.col(0), init, u.size(), &states);
  const Eigen::MatrixXd kept = states.rightCols(count);
  SsStatePrior prior;
  prior.mean = kept.rowwise().mean();
  const Eigen::MatrixXd centred = kept.colwise() - prior.mean;
  prior.covariance = centred * centred.transpose() / static_cast<double>(count - 1);
  prior.noise_variance = std::max((ys.tail(count) - out.tail(count)).squaredNorm() / static_cast<double>(count), 1e-12);
  return prior;
}

namespace {

// The whitened residual of an initial state x: the first `init` output errors over σ, then L⁻¹(x − μ)
// (Σ = L·Lᵀ), for Eigen's Levenberg–Marquardt.
struct InitialStateResidual {
  using Scalar = double;
  using InputType = Eigen::VectorXd;
  using ValueType = Eigen::VectorXd;
  using JacobianType = Eigen::MatrixXd;
  enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };

  const SsModel* model;
  const Eigen::VectorXd* us;
  Eigen::VectorXd measured;  ///< ys's first init samples
  Eigen::LLT<Eigen::MatrixXd> prior_factor;
  double sigma = 1.0;

  int inputs() const { return static_cast<int>(model->structure.states); }
  int values() const { return static_cast<int>(measured.size()) + inputs(); }
  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& r) const {
    const SsStatePrior& prior = *model->state_prior;
    r.resize(values());
    r.head(measured.size()) = (measured - model->run_scaled(*us, x, 0, measured.size())) / sigma;
    r.tail(inputs()) = prior_factor.matrixL().solve(x - prior.mean);
    if (!r.allFinite()) r.setConstant(1e150);  // a trial state whose run left every bound: far worse than any other
    return 0;
  }
};

}  // namespace

Eigen::VectorXd ss_fit_initial_state(const SsModel& m, const Eigen::VectorXd& us, const Eigen::VectorXd& ys, Eigen::Index init) {
  if (!m.state_prior) throw std::invalid_argument("ss_fit_initial_state: the model has no state prior");
  if (init < 1 || ys.size() < init || us.size() < init) {
    throw std::invalid_argument("ss_fit_initial_state: " + std::to_string(init) + " measured samples needed, got " +
                                std::to_string(std::min(us.size(), ys.size())));
  }
  const SsStatePrior& prior = *m.state_prior;
  const Eigen::Index n = m.structure.states;
  const double floor = 1e-9 * std::max(prior.covariance.trace() / static_cast<double>(n), 1e-300);
  InitialStateResidual residual{&m, &us, ys.head(init), Eigen::LLT<Eigen::MatrixXd>(prior.covariance + floor * Eigen::MatrixXd::Identity(n, n)),
                                std::sqrt(prior.noise_variance)};
  Eigen::NumericalDiff<InitialStateResidual> differentiated(residual);
  Eigen::LevenbergMarquardt<Eigen::NumericalDiff<InitialStateResidual>> lm(differentiated);
  Eigen::VectorXd x = prior.mean;
  lm.minimize(x);
  if (!x.allFinite() || !m.run_scaled(us, x, 0, init).allFinite()) return prior.mean;
  return x;
}

}  // namespace panelbass::models

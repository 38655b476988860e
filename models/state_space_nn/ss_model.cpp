#include "models/state_space_nn/ss_model.h"

#include <Eigen/LU>
#include <random>
#include <span>
#include <stdexcept>
#include <string>

#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/model_header.h"
#include "models/narx/free_run.h"
#include "models/narx/mlp_kernel.h"
#include "models/state_space_nn/ss_initial_state.h"

namespace panelbass::models {
namespace {

constexpr const char* kSsKind = "ss";

template <class Scalar>
SsParts<Scalar> parts_of(const SsStructure& s, Scalar* theta) {
  const Eigen::Index n = s.states, h = s.hidden, l2 = 2 * s.lags, e = s.encoder_hidden;
  Eigen::Index at = 0;
  auto take = [&](Eigen::Index rows, Eigen::Index cols) {
    typename SsParts<Scalar>::Map m(theta + at, rows, cols);
    at += rows * cols;
    return m;
  };
  // Braced initialisation runs left to right: the parts in θ's order.
  return SsParts<Scalar>{take(n, n),     take(n, 1),  take(1, n),  take(1, 1),  take(h, n + 1),
                         take(h, 1),     take(n + 1, h), take(n + 1, 1), take(n, l2), take(n, 1),
                         take(e, l2),    take(e, 1),  take(n, e),  take(n + 1, s.monomial_count()), s.poly_degree,
                         s.poly_variables(), s.activation, s.hidden_input};
}

// Appends to `out` every non-decreasing index list of length `degree` from `first` on, after `prefix`.
void append_monomials(int variables, int degree, int first, std::vector<int>& prefix, std::vector<std::vector<int>>& out) {
  if (degree == 0) {
    out.push_back(prefix);
    return;
  }
  for (int i = first; i < variables; ++i) {
    prefix.push_back(i);
    append_monomials(variables, degree - 1, i, prefix, out);
    prefix.pop_back();
  }
}

void tanh_matrix(Eigen::MatrixXd& m) { tanh_in_place(std::span<double>(m.data(), static_cast<std::size_t>(m.size()))); }

}  // namespace

Eigen::Index SsStructure::parameter_count() const {
  const Eigen::Index n = states, h = hidden, l2 = 2 * static_cast<Eigen::Index>(lags), e = encoder_hidden;
  return n * n + 2 * n + 1 + h * (n + 1) + h + (n + 1) * h + (n + 1) + n * l2 + n + e * l2 + e + n * e +
         (n + 1) * monomial_count();
}

int SsStructure::poly_variables() const {
  if (poly_states > 0) return poly_states;
  return states + (poly_input ? 1 : 0);
}

Eigen::Index SsStructure::monomial_count() const {
  // monomials of v variables of degree exactly d: C(v + d − 1, d)
  const Eigen::Index variables = poly_variables();
  Eigen::Index count = 0, of_degree = variables;  // degree 1
  for (int d = 2; d <= poly_degree; ++d) {
    of_degree = of_degree * (variables + d - 1) / d;
    count += of_degree;
  }
  return count;
}

void SsStructure::check() const {
  auto within = [](const char* name, int v, int lo, int hi) {
    if (v < lo || v > hi) {
      throw std::invalid_argument(std::string(name) + " must be within [" + std::to_string(lo) + ", " + std::to_string(hi) +
                                  "], got " + std::to_string(v));
    }
  };
  within("states", states, 1, 64);
  within("hidden", hidden, poly_degree > 0 ? 0 : 1, 1000);
  within("lags", lags, 1, 1000);
  within("encoder_hidden", encoder_hidden, 0, 1000);
  if (poly_degree != 0) within("poly_degree", poly_degree, 2, 5);
  within("poly_states", poly_states, 0, states);
  if (poly_states > 0 && poly_degree == 0) throw std::invalid_argument("poly_states needs a polynomial (poly_degree 2-5)");
  if (poly_states > 0 && poly_input) {
    throw std::invalid_argument("poly_states takes monomials of the leading states alone: poly_input must be false");
  }
}

std::vector<std::vector<int>> ss_monomial_factors(int variables, int degree) {
  std::vector<std::vector<int>> out;
  std::vector<int> prefix;
  for (int d = 2; d <= degree; ++d) append_monomials(variables, d, 0, prefix, out);
  return out;
}

void ss_monomials(const std::vector<std::vector<int>>& factors, const Eigen::Ref<const Eigen::MatrixXd>& X,
                  const Eigen::Ref<const Eigen::RowVectorXd>& U, Eigen::MatrixXd& out) {
  const Eigen::Index n = X.rows(), columns = X.cols();
  out.resize(static_cast<Eigen::Index>(factors.size()), columns);
  for (Eigen::Index b = 0; b < columns; ++b) {
    for (std::size_t m = 0; m < factors.size(); ++m) {
      double product = 1.0;
      for (const int i : factors[m]) product *= i < n ? X(i, b) : U(b);
      out(static_cast<Eigen::Index>(m), b) = product;
    }
  }
}

void ss_monomials_backward(const std::vector<std::vector<int>>& factors, const Eigen::Ref<const Eigen::MatrixXd>& X,
                           const Eigen::Ref<const Eigen::RowVectorXd>& U, const Eigen::MatrixXd& Q,
                           Eigen::Ref<Eigen::MatrixXd> dX) {
  const Eigen::Index n = X.rows(), columns = X.cols();
  for (Eigen::Index b = 0; b < columns; ++b) {
    for (std::size_t m = 0; m < factors.size(); ++m) {
      const double q = Q(static_cast<Eigen::Index>(m), b);
      const std::vector<int>& f = factors[m];
      // ∂(v_f0·v_f1·…)/∂v_f[j] = the product of the other factors, summed over the positions j of x_i
      for (std::size_t j = 0; j < f.size(); ++j) {
        if (f[j] >= n) continue;
        double others = q;
        for (std::size_t r = 0; r < f.size(); ++r) {
          if (r != j) others *= f[r] < n ? X(f[r], b) : U(b);
        }
        dX(f[j], b) += others;
      }
    }
  }
}

void ss_activate(SsActivation activation, const Eigen::MatrixXd& pre, Eigen::MatrixXd& out) {
  out = pre;
  if (activation == SsActivation::tanh) {
    tanh_matrix(out);
  } else {
    out.array() = pre.array().cube();
  }
}

Eigen::ArrayXXd ss_activation_slope(SsActivation activation, const Eigen::Ref<const Eigen::MatrixXd>& pre,
                                    const Eigen::Ref<const Eigen::MatrixXd>& out) {
  if (activation == SsActivation::tanh) return 1.0 - out.array().square();
  return 3.0 * pre.array().square();
}

const char* ss_activation_name(SsActivation activation) { return activation == SsActivation::tanh ? "tanh" : "cubic"; }

SsActivation ss_activation_from_name(const std::string& name) {
  if (name == "tanh") return SsActivation::tanh;
  if (name == "cubic") return SsActivation::cubic;
  throw std::invalid_argument("activation must be \"tanh\" or \"cubic\", got \"" + name + "\"");
}

SsParts<const double> ss_parts(const SsStructure& s, const double* theta) { return parts_of<const double>(s, theta); }
SsParts<double> ss_parts(const SsStructure& s, double* theta) { return parts_of<double>(s, theta); }

void ss_step(const SsParts<const double>& p, const Eigen::Ref<const Eigen::MatrixXd>& X,
             const Eigen::Ref<const Eigen::RowVectorXd>& U, SsStepWork& work, Eigen::Ref<Eigen::RowVectorXd> Y,
             Eigen::Ref<Eigen::MatrixXd> X_next) {
  const Eigen::Index n = X.rows();
  // [f; h] = W2·σ(W1·[x; u] + b1) + b2 (W1's input column unread without hidden_input)
  work.pre.noalias() = p.W1.leftCols(n) * X;
  if (p.hidden_input) work.pre.noalias() += p.W1.col(n) * U;
  work.pre.colwise() += p.b1.col(0);
  ss_activate(p.activation, work.pre, work.hidden);
  work.network.noalias() = p.W2 * work.hidden;
  work.network.colwise() += p.b2.col(0);
  if (p.P.cols() > 0) {
    // + P·ζ(x, u)
    if (static_cast<Eigen::Index>(work.factors.size()) != p.P.cols()) work.factors = ss_monomial_factors(p.poly_variables, p.poly_degree);
    ss_monomials(work.factors, X, U, work.monomials);
    work.network.noalias() += p.P * work.monomials;
  }
  // y(k) = C·x + D·u + h,   x(k+1) = A·x + B·u + f
  Y.noalias() = p.C * X;
  Y += p.D(0, 0) * U + work.network.row(n);
  X_next.noalias() = p.A * X;
  X_next.noalias() += p.B * U;
  X_next += work.network.topRows(n);
}

void ss_encode(const SsParts<const double>& p, const Eigen::Ref<const Eigen::MatrixXd>& Z, Eigen::MatrixXd& hidden,
               Eigen::Ref<Eigen::MatrixXd> X0) {
  // x(k0) = E·z + V2·tanh(V1·z + c1) + c2
  X0.noalias() = p.E * Z;
  X0.colwise() += p.c2.col(0);
  if (p.V1.rows() == 0) return;
  hidden.noalias() = p.V1 * Z;
  hidden.colwise() += p.c1.col(0);
  tanh_matrix(hidden);
  X0.noalias() += p.V2 * hidden;
}

void ss_regressor(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index k, int lags,
                  Eigen::Ref<Eigen::VectorXd> z) {
  for (int i = 0; i < lags; ++i) {
    const Eigen::Index at = k - 1 - i;
    const bool inside = at >= 0;
    z(i) = inside && at < y.size() ? y(at) : 0.0;
    z(lags + i) = inside && at < u.size() ? u(at) : 0.0;
  }
}

StateSpace SsModel::linear_part() const {
  const auto p = ss_parts(structure, theta.data());
  StateSpace ss;
  ss.A = p.A;
  ss.B = p.B.col(0);
  ss.C = p.C.row(0);
  ss.D = p.D(0, 0);
  return ss;
}

Eigen::VectorXd ss_network_jacobian(const SsParts<const double>& p, const Eigen::VectorXd& x, double u,
                                    const std::vector<std::vector<int>>& factors, Eigen::MatrixXd& jacobian) {
  const Eigen::Index n = x.size();
  Eigen::VectorXd z(n + 1);
  z << x, u;
  Eigen::MatrixXd w1 = p.W1;
  if (!p.hidden_input) w1.col(n).setZero();
  const Eigen::MatrixXd pre = w1 * z + p.b1.col(0);
  Eigen::MatrixXd t;
  ss_activate(p.activation, pre, t);
  Eigen::VectorXd network = p.W2 * t + p.b2.col(0);
  // ∂(W2·σ(W1·z + b1))/∂z = W2·diag(σ′)·W1
  jacobian = p.W2 * ss_activation_slope(p.activation, pre, t).matrix().col(0).asDiagonal() * w1;
  for (std::size_t m = 0; m < factors.size(); ++m) {
    const std::vector<int>& f = factors[m];
    double product = 1.0;
    for (const int i : f) product *= z(i);
    network += p.P.col(static_cast<Eigen::Index>(m)) * product;
    // ∂(z_f0·z_f1·…)/∂z_f[j] = the product of the other factors, summed over the positions j
    for (std::size_t j = 0; j < f.size(); ++j) {
      double others = 1.0;
      for (std::size_t r = 0; r < f.size(); ++r) {
        if (r != j) others *= z(f[r]);
      }
      jacobian.col(f[j]) += p.P.col(static_cast<Eigen::Index>(m)) * others;
    }
  }
  return network;
}

StateSpace SsModel::linearization() const {
  const auto p = ss_parts(structure, theta.data());
  const Eigen::Index n = structure.states;
  const std::vector<std::vector<int>> factors =
      structure.poly_degree > 0 ? ss_monomial_factors(p.poly_variables, p.poly_degree) : std::vector<std::vector<int>>{};
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  Eigen::MatrixXd jacobian;
  bool converged = false;
  for (int it = 0; it < 100 && !converged; ++it) {
    // Newton on r(x) = A·x + f(x, 0) − x
    const Eigen::VectorXd network = ss_network_jacobian(p, x, 0.0, factors, jacobian);
    const Eigen::VectorXd r = p.A * x + network.head(n) - x;
    const Eigen::MatrixXd dr = p.A + jacobian.topLeftCorner(n, n) - Eigen::MatrixXd::Identity(n, n);
    const Eigen::VectorXd dx = dr.fullPivLu().solve(r);
    if (!dx.allFinite()) break;
    x -= dx;
    converged = dx.norm() <= 1e-12 * (1.0 + x.norm());
  }
  if (!converged || !x.allFinite()) {
    throw std::invalid_argument("SsModel::linearization: no equilibrium found at zero input");
  }
  ss_network_jacobian(p, x, 0.0, factors, jacobian);
  StateSpace ss;
  ss.A = p.A + jacobian.topLeftCorner(n, n);
  ss.B = p.B.col(0) + jacobian.col(n).head(n);
  ss.C = p.C.row(0) + jacobian.row(n).head(n);
  ss.D = p.D(0, 0) + jacobian(n, n);
  return ss;
}

Eigen::VectorXd SsModel::simulate_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) const {
  if (init > 0 && y.size() < std::min(init, u.size())) {
    throw std::invalid_argument("SsModel::simulate: " + std::to_string(init) + " measured outputs requested, got " +
                                std::to_string(y.size()));
  }
  const Eigen::Index samples = u.size(), start = std::min(init, samples);
  Eigen::VectorXd out(samples);
  if (state_prior && start > 0) {
    out = run_scaled(u, ss_fit_initial_state(*this, u, y, start), 0, samples);
  } else {
    Eigen::VectorXd z(2 * structure.lags);
    ss_regressor(u, y.size() != 0 ? y.head(start).eval() : Eigen::VectorXd(), start, structure.lags, z);
    Eigen::MatrixXd x(structure.states, 1), encoder_hidden;
    ss_encode(ss_parts(structure, theta.data()), z, encoder_hidden, x);
    out.tail(samples - start) = run_scaled(u, x.col(0), start, samples);
  }
  if (start > 0) out.head(start) = y.head(start);
  return out;
}

Eigen::VectorXd SsModel::run_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& x0, Eigen::Index begin, Eigen::Index end,
                                    Eigen::MatrixXd* states) const {
  const auto p = ss_parts(structure, theta.data());
  Eigen::MatrixXd x = x0, next(x0.size(), 1);
  if (states != nullptr) states->resize(x0.size(), end - begin);
  Eigen::VectorXd out(end - begin);
  SsStepWork work;
  Eigen::RowVectorXd uk(1), yk(1);
  for (Eigen::Index k = begin; k < end; ++k) {
    if (states != nullptr) states->col(k - begin) = x.col(0);
    uk(0) = u(k);
    ss_step(p, x, uk, work, yk, next);
    out(k - begin) = yk(0);
    x.swap(next);
  }
  return out;
}

Eigen::VectorXd SsModel::predict_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const {
  if (y.size() != u.size()) throw std::invalid_argument("SsModel::predict: input and output lengths differ");
  const auto p = ss_parts(structure, theta.data());
  const Eigen::Index samples = u.size();
  Eigen::MatrixXd Z(2 * structure.lags, samples);
  for (Eigen::Index k = 0; k < samples; ++k) ss_regressor(u, y, k, structure.lags, Z.col(k));
  Eigen::MatrixXd X(structure.states, samples), next(structure.states, samples), encoder_hidden;
  ss_encode(p, Z, encoder_hidden, X);
  SsStepWork work;
  Eigen::RowVectorXd out(samples);
  ss_step(p, X, u.transpose(), work, out, next);
  return out.transpose();
}

Eigen::VectorXd SsModel::simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) const {
  const Eigen::VectorXd ys = y.size() != 0 ? scaling.scale_y(y) : Eigen::VectorXd();
  return scaling.unscale_y(simulate_scaled(scaling.scale_u(u), ys, init));
}

Eigen::VectorXd SsModel::predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const {
  return scaling.unscale_y(predict_scaled(scaling.scale_u(u), scaling.scale_y(y)));
}

SsModel ss_model_from_linear(const StateSpace& linear, SsStructure s, const Eigen::VectorXd& state_scale,
                             const Scaling& scaling, double fs, std::uint64_t seed) {
  check_shape(linear, "ss_model_from_linear");
  s.states = linear.order();
  s.check();
  if (state_scale.size() != s.states || !(state_scale.array() > 0.0).all() || !state_scale.allFinite()) {
    throw std::invalid_argument("ss_model_from_linear: state_scale needs " + std::to_string(s.states) +
                                " finite positive entries");
  }
  SsModel m;
  m.structure = s;
  m.scaling = scaling;
  m.fs = fs;
  m.theta = Eigen::VectorXd::Zero(s.parameter_count());
  auto p = ss_parts(s, m.theta.data());
  p.A = linear.A;
  p.B.col(0) = linear.B;
  p.C.row(0) = linear.C;
  p.D(0, 0) = linear.D;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  // Each node's input of typical size ≈ 1 at the start: weights ±1/(scale·√inputs), biases ±0.5.
  const double per_input = 1.0 / std::sqrt(static_cast<double>(s.states + 1));
  for (Eigen::Index j = 0; j <= s.states; ++j) {
    const double scale = j < s.states ? state_scale(j) : 1.0;
    for (Eigen::Index i = 0; i < s.hidden; ++i) p.W1(i, j) = unit(rng) * per_input / scale;
  }
  if (!s.hidden_input) p.W1.col(s.states).setZero();
  for (Eigen::Index i = 0; i < s.hidden; ++i) p.b1(i, 0) = 0.5 * unit(rng);
  const double per_lag = 1.0 / std::sqrt(2.0 * s.lags);
  for (Eigen::Index j = 0; j < p.V1.cols(); ++j)
    for (Eigen::Index i = 0; i < p.V1.rows(); ++i) p.V1(i, j) = unit(rng) * per_lag;
  for (Eigen::Index i = 0; i < p.c1.rows(); ++i) p.c1(i, 0) = 0.5 * unit(rng);
  return m;
}

nlohmann::json ss_model_to_json(const SsModel& m) {
  nlohmann::json j = {
      {"format", kModelFormat},
      {"kind", kSsKind},
      {"fs", m.fs},
      {"scaling", scaling_to_json(m.scaling)},
      {"params",
       {{"states", m.structure.states},
        {"hidden", m.structure.hidden},
        {"lags", m.structure.lags},
        {"encoder_hidden", m.structure.encoder_hidden},
        {"poly_degree", m.structure.poly_degree},
        {"poly_input", m.structure.poly_input},
        {"poly_states", m.structure.poly_states},
        {"activation", ss_activation_name(m.structure.activation)},
        {"hidden_input", m.structure.hidden_input},
        {"theta", to_array(m.theta)}}},
      {"meta", m.meta.is_null() ? nlohmann::json::object() : m.meta},
  };
  if (m.state_prior) {
    const SsStatePrior& prior = *m.state_prior;
    j["params"]["initial_state"] = {
        {"state_mean", to_array(prior.mean)},
        {"state_covariance", to_rows(prior.covariance)},
        {"noise_variance", prior.noise_variance}};
  }
  return j;
}

std::optional<Runaway> ss_free_run_runaway(const SsModel& m) { return runaway(m.simulate_scaled(free_run_drive())); }

namespace {

// The "initial_state" member: the prior's mean (nx), covariance (nx rows of nx, symmetric) and noise
// variance (> 0), each checked and named by its path.
SsStatePrior state_prior_from_json(const nlohmann::json& j, const std::string& path, int states) {
  JsonFields f(j, path);
  auto required = [&](const char* key) {
    const nlohmann::json* v = f.member(key);
    if (v == nullptr) throw ConfigError(f.path_of(key) + ": missing");
    return v;
  };
  SsStatePrior prior;
  prior.mean = read_vector(*required("state_mean"), f.path_of("state_mean"));
  if (prior.mean.size() != states) {
    throw ConfigError(f.path_of("state_mean") + ": expected " + std::to_string(states) + " numbers (the states), got " +
                      std::to_string(prior.mean.size()));
  }
  prior.covariance = read_matrix(*required("state_covariance"), f.path_of("state_covariance"), states, states);
  if (!(prior.covariance - prior.covariance.transpose()).isZero(1e-9 * (1.0 + prior.covariance.cwiseAbs().maxCoeff())) ||
      (prior.covariance.diagonal().array() < 0.0).any()) {
    throw ConfigError(f.path_of("state_covariance") + ": not a covariance (asymmetric, or a negative variance)");
  }
  prior.noise_variance = f.number("noise_variance");
  require_positive(prior.noise_variance, f.path_of("noise_variance"));
  f.finish();
  return prior;
}

}  // namespace

SsModel ss_model_shape_from_json(const nlohmann::json& j) {
  JsonFields top(j, "model");
  SsModel m;
  m.fs = read_model_header(top, kSsKind);
  m.scaling = read_model_scaling(top);
  const nlohmann::json& params = read_model_params(top);
  JsonFields p(params, "model.params");
  auto size = [&](const char* key, long lo, long hi) {
    if (!params.contains(key)) throw ConfigError(p.path_of(key) + ": missing");
    return static_cast<int>(p.integer(key, 0, lo, hi));
  };
  m.structure.states = size("states", 1, 64);
  m.structure.hidden = size("hidden", 0, 1000);
  m.structure.lags = size("lags", 1, 1000);
  m.structure.encoder_hidden = static_cast<int>(p.integer("encoder_hidden", 0, 0, 1000));
  m.structure.poly_degree = static_cast<int>(p.integer("poly_degree", 0, 0, 5));
  m.structure.poly_states = static_cast<int>(p.integer("poly_states", 0, 0, 64));
  m.structure.poly_input = p.boolean("poly_input", m.structure.poly_states == 0);
  m.structure.hidden_input = p.boolean("hidden_input", true);
  try {
    m.structure.activation = ss_activation_from_name(p.string("activation", "tanh"));
  } catch (const std::invalid_argument& e) {
    throw ConfigError(p.path_of("activation") + ": " + e.what());
  }
  try {
    m.structure.check();  // poly_degree 1, hidden 0 without the polynomial, or poly_states beyond the states
  } catch (const std::invalid_argument& e) {
    throw ConfigError("model.params: " + std::string(e.what()));
  }
  const nlohmann::json* theta = p.member("theta");
  if (theta == nullptr) throw ConfigError(p.path_of("theta") + ": missing");
  m.theta = read_vector(*theta, p.path_of("theta"));
  const Eigen::Index count = m.structure.parameter_count();
  if (m.theta.size() != count) {
    throw ConfigError(p.path_of("theta") + ": expected " + std::to_string(count) + " numbers for these sizes, got " +
                      std::to_string(m.theta.size()));
  }
  if (const nlohmann::json* prior = p.member("initial_state")) m.state_prior = state_prior_from_json(*prior, p.path_of("initial_state"), m.structure.states);
  p.finish();
  m.meta = read_model_meta(top);
  top.finish();
  return m;
}

SsModel ss_model_from_json(const nlohmann::json& j) {
  SsModel m = ss_model_shape_from_json(j);
  if (const auto r = ss_free_run_runaway(m)) {
    throw ConfigError("model: free run unbounded: |y| = " + std::to_string(r->magnitude) + " after " +
                      std::to_string(r->samples) + " samples of full-scale noise (scaled units)");
  }
  return m;
}

}  // namespace panelbass::models

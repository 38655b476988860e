#include "models/control/lq_feedforward.h"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

#include "dsp/frequency_grid.h"
#include "dsp/random.h"
#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/model_header.h"
#include "models/io/number_text.h"

namespace panelbass::models {
namespace {

constexpr const char* kLqFeedforwardKind = "lq_feedforward";

// max_input(): the impulse response is summed until a block of it adds less than this fraction of the
// sum, each block at least one time constant long (so the rest of the tail is below it as well).
constexpr double kTailFraction = 1e-12;
constexpr Eigen::Index kMaxImpulseSamples = 1000000;
constexpr Eigen::Index kMinBlock = 256;

// The spectral radius of a double-precision matrix.
double spectral_radius(const Eigen::MatrixXd& A) {
  if (A.rows() == 0) return 0.0;
  return Eigen::EigenSolver<Eigen::MatrixXd>(A, false).eigenvalues().cwiseAbs().maxCoeff();
}

Eigen::MatrixXd read_matrix(const nlohmann::json& v, const std::string& path) {
  if (!v.is_array()) throw ConfigError(path + ": expected an array of rows, got " + std::string(v.type_name()));
  const auto n = static_cast<Eigen::Index>(v.size());
  Eigen::MatrixXd M(n, n);
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::string row_path = path + "[" + std::to_string(i) + "]";
    const Eigen::VectorXd row = read_vector(v[i], row_path);
    if (row.size() != n) {
      throw ConfigError(row_path + ": " + std::to_string(row.size()) + " entries, A must be square (" +
                        std::to_string(n) + " rows)");
    }
    M.row(static_cast<Eigen::Index>(i)) = row.transpose();
  }
  return M;
}

nlohmann::json matrix_to_json(const Eigen::MatrixXd& M) {
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index i = 0; i < M.rows(); ++i) rows.push_back(to_array(M.row(i).transpose()));
  return rows;
}

// Samples from one time constant of the slowest pole of `ss` and the filter (at least kMinBlock).
Eigen::Index block_length(const StateSpace& ss, const std::vector<dsp::Biquad>& filter) {
  double radius = spectral_radius(ss.A);
  for (const dsp::Biquad& s : filter) {
    Eigen::Matrix2d companion;
    companion << -s.a1, -s.a2, 1.0, 0.0;
    radius = std::max(radius, spectral_radius(Eigen::MatrixXd(companion)));
  }
  if (!(radius < 1.0)) return kMaxImpulseSamples;
  const double time_constant = -1.0 / std::log(std::max(radius, 1e-300));
  return std::clamp<Eigen::Index>(static_cast<Eigen::Index>(std::ceil(time_constant)), kMinBlock, kMaxImpulseSamples);
}

}  // namespace

StateSpace LqFeedforward::controller() const {
  // [7B] x(k+1) = (A − BL)·x(k) + B·u(k),  u*(k) = −L·x(k) + u(k)
  StateSpace ss;
  ss.A = plant.A - plant.B * L;
  ss.B = plant.B;
  ss.C = -L;
  ss.D = 1.0;
  return ss;
}

StateSpace LqFeedforward::desired() const {
  // [7B] x(k+1) = (A − BL)·x(k) + B·u(k),  y_lin(k) = (C − D·L)·x(k) + D·u(k)  (the thesis's D = 0)
  StateSpace ss;
  ss.A = plant.A - plant.B * L;
  ss.B = plant.B;
  ss.C = plant.C - plant.D * L;
  ss.D = plant.D;
  return ss;
}

Eigen::VectorXcd LqFeedforward::poles() const {
  if (plant.order() == 0) return Eigen::VectorXcd(0);
  return Eigen::EigenSolver<Eigen::MatrixXd>(plant.A - plant.B * L, false).eigenvalues();
}

Eigen::VectorXcd LqFeedforward::zeros() const {
  if (plant.order() == 0) return Eigen::VectorXcd(0);
  // The zeros of (Ac, Bc, Cc, Dc) with Dc = 1 are the eigenvalues of Ac − Bc·Dc⁻¹·Cc = A − BL + BL = A.
  const StateSpace c = controller();
  return Eigen::EigenSolver<Eigen::MatrixXd>(c.A - c.B * c.C / c.D, false).eigenvalues();
}

LqFeedforward design_lq(const LinearModel& model, const LqWeights& weights) {
  if (!std::isfinite(weights.R) || !(weights.R > 0.0)) {
    throw std::invalid_argument("design_lq: R must be > 0, got " + number_text(weights.R));
  }
  if (!std::isfinite(weights.R0) || !(weights.R0 >= 0.0)) {
    throw std::invalid_argument("design_lq: R0 must be >= 0, got " + number_text(weights.R0));
  }
  if (!std::isfinite(model.fs) || !(model.fs > 0.0)) {
    throw std::invalid_argument("design_lq: model fs must be > 0, got " + number_text(model.fs));
  }
  if (!model.tf.all_finite()) throw std::invalid_argument("design_lq: model has a non-finite coefficient");
  const Scaling& s = model.scaling;
  if (!(std::isfinite(s.u_scale) && s.u_scale > 0.0 && std::isfinite(s.y_scale) && s.y_scale > 0.0)) {
    throw std::invalid_argument("design_lq: model scaling must have finite positive scales (u_scale " +
                                number_text(s.u_scale) + ", y_scale " + number_text(s.y_scale) + ")");
  }
  if (!model.tf.is_stable()) {
    const Eigen::VectorXcd p = model.tf.poles();
    Eigen::Index worst = 0;
    for (Eigen::Index i = 1; i < p.size(); ++i) {
      if (std::abs(p[i]) > std::abs(p[worst])) worst = i;
    }
    throw std::invalid_argument("design_lq: model is unstable (pole of radius " + number_text(std::abs(p[worst])) + " at " +
                                number_text(std::abs(std::arg(p[worst])) * model.fs / (2.0 * std::numbers::pi)) + " Hz)");
  }

  // Design in the model's scaled units (the thesis's units): [7A] with Q = Cᵀ·R0·C, which weights
  // y = C·x (exact for the thesis's D = 0; a model without delay adds D·u* to y, unweighted here).
  const StateSpace scaled = realize(model.tf);
  const Eigen::MatrixXd Q = weights.R0 * scaled.C.transpose() * scaled.C;
  const Eigen::MatrixXd P = solve_dare(scaled.A, scaled.B, Q, weights.R);
  const Eigen::RowVectorXd L = lq_gain(scaled.A, scaled.B, P, weights.R);

  // Raw units: u_raw = u_scale·u, y_raw = y_scale·y (offsets left out), so B·u = (B/u_scale)·u_raw and
  // u*_raw = u_scale·(−L·x + u) = −(L·u_scale)·x + u_raw, which leaves A − B_raw·L_raw = A − B·L.
  LqFeedforward ff;
  ff.plant.A = scaled.A;
  ff.plant.B = scaled.B / s.u_scale;
  ff.plant.C = scaled.C * s.y_scale;
  ff.plant.D = scaled.D * s.y_scale / s.u_scale;
  ff.L = L * s.u_scale;
  ff.weights = weights;
  ff.fs = model.fs;
  ff.meta = {{"model_method", model.method}, {"order", scaled.order()}};
  return ff;
}

InputLimits max_input(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass, Eigen::Index samples,
                      std::uint64_t seed) {
  if (samples < 1) throw std::invalid_argument("max_input: samples must be >= 1, got " + std::to_string(samples));
  const StateSpace c = ff.controller();
  const Eigen::Index n = c.order();
  if (n > 0 && !(spectral_radius(c.A) < 1.0)) {
    throw std::invalid_argument("max_input: the controller is unstable (A − B·L has a pole of radius " +
                                number_text(spectral_radius(c.A)) + ")");
  }
  for (std::size_t i = 0; i < band_pass.size(); ++i) {
    const dsp::Biquad& b = band_pass[i];
    // A biquad is stable when |a2| < 1 and |a1| < 1 + a2 (the stability triangle).
    if (!(std::abs(b.a2) < 1.0 && std::abs(b.a1) < 1.0 + b.a2)) {
      throw std::invalid_argument("max_input: band-pass section " + std::to_string(i) + " is unstable");
    }
  }

  // One sample of program → band-pass → controller → u*, from the state carried in `filter` and `x`.
  dsp::SosFilter filter(band_pass);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n), next(n);
  const auto step = [&](double in) {
    const double v = filter.process(in);
    // [7B] u*(k) = −L·x(k) + u(k),  x(k+1) = (A − BL)·x(k) + B·u(k)
    const double out = c.C.dot(x) + c.D * v;
    next.noalias() = c.A * x;
    next += c.B * v;
    x.swap(next);
    return out;
  };

  // Worst case: max|u*| ≤ ‖h‖₁·max|in|, with equality for in(k) = sign h(K − k); so 1/‖h‖₁.
  const Eigen::Index block = block_length(c, band_pass);
  double sum = 0.0;
  for (Eigen::Index k = 0; k < kMaxImpulseSamples;) {
    double block_sum = 0.0;
    for (Eigen::Index j = 0; j < block && k < kMaxImpulseSamples; ++j, ++k) block_sum += std::abs(step(k == 0 ? 1.0 : 0.0));
    sum += block_sum;
    if (block_sum <= kTailFraction * sum) break;
  }
  InputLimits limits;
  limits.worst = sum > 0.0 ? 1.0 / sum : std::numeric_limits<double>::infinity();

  // Band-limited white noise: uniform in [−1, 1], through the same chain from rest.
  filter.reset();
  x.setZero();
  dsp::Rng rng(seed);
  double peak = 0.0;
  for (Eigen::Index k = 0; k < samples; ++k) peak = std::max(peak, std::abs(step(rng.uniform(-1.0, 1.0))));
  limits.noise = peak > 0.0 ? 1.0 / peak : std::numeric_limits<double>::infinity();
  return limits;
}

namespace {
// drive_peak's and unity_gain_hz's grid: 2000 frequencies, logarithmic from 1 Hz to just below Nyquist.
Eigen::VectorXd response_grid(double fs) {
  return dsp::log_spaced(1.0, 0.999 * fs / 2.0, 2000);
}
}  // namespace

DrivePeak drive_peak(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass) {
  const dsp::SosFilter filter(band_pass);
  const StateSpace controller = ff.controller();
  const Eigen::VectorXd f = response_grid(ff.fs);
  DrivePeak peak{f[0], -std::numeric_limits<double>::infinity()};
  for (Eigen::Index k = 0; k < f.size(); ++k) {
    const double db = 20.0 * std::log10(std::abs(filter.response(f[k], ff.fs) * response(controller, f[k], ff.fs)));
    if (db > peak.gain_db) peak = {f[k], db};
  }
  return peak;
}

std::vector<double> unity_gain_hz(const LqFeedforward& ff) {
  const StateSpace controller = ff.controller();
  const auto boosts = [&](double f) { return std::abs(response(controller, f, ff.fs)) > 1.0; };
  const Eigen::VectorXd f = response_grid(ff.fs);
  std::vector<double> crossings;
  bool previous = boosts(f[0]);
  for (Eigen::Index k = 1; k < f.size(); ++k) {
    const bool current = boosts(f[k]);
    if (current != previous) {
      double lo = f[k - 1], hi = f[k];  // the gain is above 1 at one end only
      while (hi - lo > 1e-9 * hi) {
        const double mid = std::sqrt(lo * hi);
        (boosts(mid) == current ? hi : lo) = mid;
      }
      crossings.push_back(std::sqrt(lo * hi));
    }
    previous = current;
  }
  return crossings;
}

nlohmann::json lq_feedforward_to_json(const LqFeedforward& ff) {
  return {
      {"format", kModelFormat},
      {"kind", kLqFeedforwardKind},
      {"fs", ff.fs},
      {"params",
       {{"A", matrix_to_json(ff.plant.A)},
        {"B", to_array(ff.plant.B)},
        {"C", to_array(ff.plant.C.transpose())},
        {"D", ff.plant.D},
        {"L", to_array(ff.L.transpose())},
        {"R", ff.weights.R},
        {"R0", ff.weights.R0}}},
      {"meta", ff.meta.is_null() ? nlohmann::json::object() : ff.meta},
  };
}

LqFeedforward lq_feedforward_from_json(const nlohmann::json& j) {
  LqFeedforward ff;
  JsonFields top(j, "model");
  ff.fs = read_model_header(top, kLqFeedforwardKind);

  const nlohmann::json* params = top.member("params");
  if (params == nullptr) throw ConfigError("model.params: missing");
  JsonFields p(*params, "model.params");
  const auto required = [&p](const char* key) -> const nlohmann::json& {
    const nlohmann::json* v = p.member(key);
    if (v == nullptr) throw ConfigError(p.path_of(key) + ": missing");
    return *v;
  };
  ff.plant.A = read_matrix(required("A"), "model.params.A");
  const Eigen::Index n = ff.plant.A.rows();
  const auto states = [n](const Eigen::Index size, const char* key) {
    if (size != n) {
      throw ConfigError(std::string("model.params.") + key + ": " + std::to_string(size) + " entries, A has " +
                        std::to_string(n) + " states");
    }
  };
  ff.plant.B = read_vector(required("B"), "model.params.B");
  states(ff.plant.B.size(), "B");
  ff.plant.C = read_vector(required("C"), "model.params.C").transpose();
  states(ff.plant.C.size(), "C");
  ff.plant.D = p.number("D");
  ff.L = read_vector(required("L"), "model.params.L").transpose();
  states(ff.L.size(), "L");
  ff.weights.R = p.number("R");
  require_positive(ff.weights.R, "model.params.R");
  ff.weights.R0 = p.number("R0");
  require_non_negative(ff.weights.R0, "model.params.R0");
  p.finish();

  ff.meta = read_model_meta(top);
  top.finish();

  if (n > 0) {
    const Eigen::VectorXcd poles = ff.poles();
    Eigen::Index worst = 0;
    for (Eigen::Index i = 1; i < poles.size(); ++i) {
      if (std::abs(poles[i]) > std::abs(poles[worst])) worst = i;
    }
    if (!(std::abs(poles[worst]) < 1.0)) {
      throw ConfigError("model.params.L: A − B·L is unstable, pole of radius " + number_text(std::abs(poles[worst])) + " at " +
                        number_text(std::abs(std::arg(poles[worst])) * ff.fs / (2.0 * std::numbers::pi)) + " Hz");
    }
  }
  return ff;
}

}  // namespace panelbass::models

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

#include "dsp/butterworth.h"
#include "dsp/frequency_grid.h"
#include "dsp/leaky_integral.h"
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

// The transfer function of cascaded biquads: numerator and denominator multiplied out, exact trailing
// zeros (a first-order section's) dropped.
TransferFunction cascade_transfer_function(const std::vector<dsp::Biquad>& sections) {
  const auto times = [](const Eigen::VectorXd& p, double c0, double c1, double c2) {
    Eigen::VectorXd out = Eigen::VectorXd::Zero(p.size() + 2);
    for (Eigen::Index i = 0; i < p.size(); ++i) {
      out[i] += c0 * p[i];
      out[i + 1] += c1 * p[i];
      out[i + 2] += c2 * p[i];
    }
    return out;
  };
  Eigen::VectorXd num = Eigen::VectorXd::Ones(1), den = Eigen::VectorXd::Ones(1);
  for (const dsp::Biquad& s : sections) {
    num = times(num, s.b0, s.b1, s.b2);
    den = times(den, 1.0, s.a1, s.a2);
  }
  const auto trimmed = [](const Eigen::VectorXd& p) {
    Eigen::Index n = p.size();
    while (n > 1 && p[n - 1] == 0.0) --n;
    return Eigen::VectorXd(p.head(n));
  };
  TransferFunction tf;
  num = trimmed(num);
  den = trimmed(den);
  tf.b = num;
  tf.a = den.tail(den.size() - 1);
  return tf;
}

// design_lq()'s checks of the weights and the model.
void check_design_inputs(const LinearModel& model, const LqWeights& weights) {
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
}

// The controller in raw units from the scaled realisation and its scaled gain: u_raw = u_scale·u,
// y_raw = y_scale·y (offsets left out), so B·u = (B/u_scale)·u_raw and u*_raw = u_scale·(−L·x + u) =
// −(L·u_scale)·x + u_raw, which leaves A − B_raw·L_raw = A − B·L.
LqFeedforward raw_units(const LinearModel& model, const StateSpace& scaled, const Eigen::RowVectorXd& L,
                        const LqWeights& weights) {
  const Scaling& s = model.scaling;
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

// The samples before u* first reaches the model's output: nk plus the leading zero numerator coefficients.
int model_delay(const TransferFunction& tf) {
  int d = tf.nk;
  for (Eigen::Index i = 0; i < tf.b.size() && tf.b[i] == 0.0; ++i) ++d;
  return d;
}

}  // namespace

StateSpace LqFeedforward::controller() const {
  // [7B] x(k+1) = (A − BL)·x(k) + B·u(k),  u*(k) = −L·x(k) + u(k); a target adds the reference model's
  // states x_r(k+1) = A_r·x_r(k) + B_r·u(k), u*(k) = −L·x(k) − L_r·x_r(k) + l·u(k).
  const Eigen::Index n = plant.order(), m = target.model.order();
  const double l = has_target() ? target.feedthrough : 1.0;
  StateSpace ss;
  ss.A = Eigen::MatrixXd::Zero(n + m, n + m);
  ss.A.topLeftCorner(n, n) = plant.A - plant.B * L;
  ss.B = Eigen::VectorXd(n + m);
  ss.B.head(n) = plant.B * l;
  ss.C = Eigen::RowVectorXd(n + m);
  ss.C.head(n) = -L;
  if (m > 0) {
    ss.A.topRightCorner(n, m) = -plant.B * target.L;
    ss.A.bottomRightCorner(m, m) = target.model.A;
    ss.B.tail(m) = target.model.B;
    ss.C.tail(m) = -target.L;
  }
  ss.D = l;
  return ss;
}

StateSpace LqFeedforward::desired() const {
  // [7B] x(k+1) = (A − BL)·x(k) + B·u(k),  y_lin(k) = (C − D·L)·x(k) + D·u(k)  (the thesis's D = 0): the
  // model driven by controller()'s u*, so y_lin = C·x + D·u*.
  StateSpace ss = controller();
  const Eigen::Index n = plant.order();
  Eigen::RowVectorXd C = plant.D * ss.C;
  C.head(n) += plant.C;
  ss.C = C;
  ss.D = plant.D * ss.D;
  return ss;
}

Eigen::VectorXcd LqFeedforward::poles() const {
  const StateSpace c = controller();
  if (c.order() == 0) return Eigen::VectorXcd(0);
  return Eigen::EigenSolver<Eigen::MatrixXd>(c.A, false).eigenvalues();
}

Eigen::VectorXcd LqFeedforward::zeros() const {
  const StateSpace c = controller();
  if (c.order() == 0) return Eigen::VectorXcd(0);
  // The zeros of (Ac, Bc, Cc, Dc) with Dc ≠ 0 are the eigenvalues of Ac − Bc·Dc⁻¹·Cc; without a target
  // Dc = 1 and that is A − BL + BL = A.
  if (c.D != 0.0) return Eigen::EigenSolver<Eigen::MatrixXd>(c.A - c.B * c.C / c.D, false).eigenvalues();
  return to_transfer_function(c).zeros();
}

LqFeedforward design_lq(const LinearModel& model, const LqWeights& weights) {
  check_design_inputs(model, weights);
  // Design in the model's scaled units (the thesis's units): [7A] with Q = Cᵀ·R0·C, which weights
  // y = C·x (exact for the thesis's D = 0; a model without delay adds D·u* to y, unweighted here).
  const StateSpace scaled = realize(model.tf);
  const Eigen::MatrixXd Q = weights.R0 * scaled.C.transpose() * scaled.C;
  const Eigen::MatrixXd P = solve_dare(scaled.A, scaled.B, Q, weights.R);
  return raw_units(model, scaled, lq_gain(scaled.A, scaled.B, P, weights.R), weights);
}

LqFeedforward design_lq(const LinearModel& model, const LqWeights& weights, const LqTargetBand& band) {
  check_design_inputs(model, weights);
  const double nyquist = model.fs / 2.0;
  const auto check_hz = [nyquist](double hz, const char* what) {
    if (!std::isfinite(hz) || !(hz > 0.0 && hz < nyquist)) {
      throw std::invalid_argument(std::string("design_lq: the target's ") + what + " must be in (0, fs/2 = " +
                                  number_text(nyquist) + ") Hz, got " + number_text(hz));
    }
  };
  check_hz(band.highpass_hz, "high-pass corner");
  check_hz(band.mid_hz, "mid-band frequency");
  if (band.order < 1 || band.order > 8) {
    throw std::invalid_argument("design_lq: the target's high-pass order must be in 1…8, got " + std::to_string(band.order));
  }

  // The reference model in scaled units: gain·z^−d·HP(z), HP's gain at mid band that of the model there, its
  // sign the one nearer the model's phase; d the model's delay (≥ 1, so y_r(k) depends on u up to k − d).
  const std::vector<dsp::Biquad> highpass = dsp::butterworth_highpass(band.order, band.highpass_hz, model.fs);
  const int delay = std::max(1, model_delay(model.tf));
  const double w_mid = 2.0 * std::numbers::pi * band.mid_hz / model.fs;
  const std::complex<double> hp_mid = dsp::SosFilter(highpass).response(band.mid_hz, model.fs) *
                                      std::polar(1.0, -w_mid * delay);
  const std::complex<double> model_mid = model.tf.response(band.mid_hz, model.fs);
  const double sign = (model_mid * std::conj(hp_mid)).real() >= 0.0 ? 1.0 : -1.0;
  const double gain = sign * std::abs(model_mid) / std::abs(hp_mid);
  TransferFunction reference_tf = cascade_transfer_function(highpass);
  reference_tf.b *= gain;
  reference_tf.nk = delay;
  const StateSpace reference = realize(reference_tf);

  // [7A] on the augmented state ξ = [x; x_r]: ξ(k+1) = Ã·ξ(k) + B̃·u*(k) + Ẽ·u(k), the tracking error
  // e = C·x − C_r·x_r (D_r = 0 by the delay; a model without delay adds D·u*, unweighted as in design_lq),
  // Q = R0·[C, −C_r]ᵀ·[C, −C_r]. With u(k) known and the later program white (zero mean), the cost to go
  // is ξᵀPξ + const and u*(k) = −(R + B̃ᵀPB̃)⁻¹·B̃ᵀP·(Ã·ξ(k) + Ẽ·u(k)) = −L̃·ξ(k) + l·u(k).
  const StateSpace scaled = realize(model.tf);
  const Eigen::Index n = scaled.order(), m = reference.order();
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n + m, n + m);
  A.topLeftCorner(n, n) = scaled.A;
  A.bottomRightCorner(m, m) = reference.A;
  Eigen::VectorXd B = Eigen::VectorXd::Zero(n + m), E = Eigen::VectorXd::Zero(n + m);
  B.head(n) = scaled.B;
  E.tail(m) = reference.B;
  Eigen::RowVectorXd H(n + m);
  H << scaled.C, -reference.C;
  const Eigen::MatrixXd Q = weights.R0 * H.transpose() * H;
  const Eigen::MatrixXd P = solve_dare(A, B, Q, weights.R);
  const Eigen::RowVectorXd L = lq_gain(A, B, P, weights.R);
  const Eigen::VectorXd PB = P * B;
  const double feedthrough = -PB.dot(E) / (weights.R + B.dot(PB));

  // Raw units as in design_lq; the program enters the reference scaled (w = u_raw/u_scale) and y_r leaves raw.
  const Scaling& s = model.scaling;
  LqFeedforward ff = raw_units(model, scaled, L.head(n), weights);
  ff.target.band = band;
  ff.target.gain = gain * s.y_scale / s.u_scale;
  ff.target.delay = delay;
  ff.target.model.A = reference.A;
  ff.target.model.B = reference.B / s.u_scale;
  ff.target.model.C = reference.C * s.y_scale;
  ff.target.model.D = reference.D * s.y_scale / s.u_scale;
  ff.target.L = L.tail(m) * s.u_scale;
  ff.target.feedthrough = feedthrough;
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

double noise_excursion(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass, Eigen::Index samples,
                       std::uint64_t seed) {
  if (samples < 1) throw std::invalid_argument("noise_excursion: samples must be >= 1, got " + std::to_string(samples));
  // max_input()'s noise: uniform in [−1, 1] from dsp::Rng(seed), band-passed, from rest.
  dsp::SosFilter filter(band_pass);
  dsp::Rng rng(seed);
  Eigen::VectorXd program(samples);
  for (Eigen::Index k = 0; k < samples; ++k) program[k] = filter.process(rng.uniform(-1.0, 1.0));
  const Eigen::VectorXd y_lin = simulate(ff.desired(), program);
  return dsp::leaky_integral(dsp::leaky_integral(y_lin, ff.fs), ff.fs).cwiseAbs().maxCoeff();
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
  nlohmann::json j = {
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
  if (ff.has_target()) {
    const LqTarget& t = ff.target;
    j["params"]["target"] = {{"highpass_hz", t.band.highpass_hz},
                             {"order", t.band.order},
                             {"mid_hz", t.band.mid_hz},
                             {"gain", t.gain},
                             {"delay", t.delay},
                             {"A", matrix_to_json(t.model.A)},
                             {"B", to_array(t.model.B)},
                             {"C", to_array(t.model.C.transpose())},
                             {"D", t.model.D},
                             {"L", to_array(t.L.transpose())},
                             {"feedthrough", t.feedthrough}};
  }
  return j;
}

namespace {

// Reads A (square), B, C, D and L of `f` into `ss` and `L`, checking that B, C and L have A's size;
// ConfigError names the key ("model.params.L: 7 entries, A has 8 states").
void read_feedback_system(JsonFields& f, StateSpace& ss, Eigen::RowVectorXd& L) {
  const auto required = [&f](const char* key) -> const nlohmann::json& {
    const nlohmann::json* v = f.member(key);
    if (v == nullptr) throw ConfigError(f.path_of(key) + ": missing");
    return *v;
  };
  ss.A = read_matrix(required("A"), f.path_of("A"));
  const Eigen::Index n = ss.A.rows();
  const auto states = [&f, n](const Eigen::Index size, const char* key) {
    if (size != n) {
      throw ConfigError(f.path_of(key) + ": " + std::to_string(size) + " entries, A has " + std::to_string(n) + " states");
    }
  };
  ss.B = read_vector(required("B"), f.path_of("B"));
  states(ss.B.size(), "B");
  ss.C = read_vector(required("C"), f.path_of("C")).transpose();
  states(ss.C.size(), "C");
  ss.D = f.number("D");
  L = read_vector(required("L"), f.path_of("L")).transpose();
  states(L.size(), "L");
}

}  // namespace

LqFeedforward lq_feedforward_from_json(const nlohmann::json& j) {
  LqFeedforward ff;
  JsonFields top(j, "model");
  ff.fs = read_model_header(top, kLqFeedforwardKind);

  JsonFields p(read_model_params(top), "model.params");
  read_feedback_system(p, ff.plant, ff.L);
  ff.weights.R = p.number("R");
  require_positive(ff.weights.R, "model.params.R");
  ff.weights.R0 = p.number("R0");
  require_non_negative(ff.weights.R0, "model.params.R0");
  if (const nlohmann::json* target = p.member("target")) {
    JsonFields t(*target, "model.params.target");
    LqTarget& r = ff.target;
    read_feedback_system(t, r.model, r.L);
    r.band.highpass_hz = t.number("highpass_hz");
    require_positive(r.band.highpass_hz, "model.params.target.highpass_hz");
    r.band.order = static_cast<int>(t.integer("order", 2, 1, 8));
    r.band.mid_hz = t.number("mid_hz");
    require_positive(r.band.mid_hz, "model.params.target.mid_hz");
    r.gain = t.number("gain");
    r.delay = static_cast<int>(t.integer("delay", 1, 0, 1000000));
    r.feedthrough = t.number("feedthrough");
    t.finish();
    if (r.model.order() == 0) throw ConfigError("model.params.target.A: the reference model has no states");
  }
  p.finish();

  ff.meta = read_model_meta(top);
  top.finish();

  if (ff.plant.order() > 0) {
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

#include "models/oscillator/oscillator_model.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/model_header.h"
#include "models/narx/free_run.h"
#include "models/optimization/levenberg_marquardt.h"

namespace panelbass::models {
namespace {

constexpr const char* kOscillatorKind = "oscillator";
constexpr OscillatorTerm kAllTerms[] = {OscillatorTerm::y2,  OscillatorTerm::y3, OscillatorTerm::y_abs_y,
                                        OscillatorTerm::v_log_v, OscillatorTerm::y_v, OscillatorTerm::v2,
                                        OscillatorTerm::y_v2, OscillatorTerm::v_y2};
/// The outputs a predictor's initial state is fitted to (the benchmarks' protocol).
constexpr Eigen::Index kPredictorInit = 50;

std::string term_names() {
  std::string names;
  for (OscillatorTerm t : kAllTerms) names += std::string(names.empty() ? "" : ", ") + oscillator_term_name(t);
  return names;
}

/// The state's acceleration and its partial derivatives at one RK4 stage.
struct Acceleration {
  double value = 0.0;  ///< v̇
  double dy = 0.0;     ///< ∂v̇/∂y
  double dv = 0.0;     ///< ∂v̇/∂v
};

/// v̇ = −d·v − k·y − Σ c_i·φ_i(y, v) + g·(ũ + u₀) at (y, v) with input ũ; `phi` receives the φ_i.
Acceleration acceleration(const OscillatorStructure& s, const Eigen::VectorXd& theta, double y, double v, double u,
                          double* phi) {
  Acceleration a;
  a.value = -theta(kOscDamping) * v - theta(kOscStiffness) * y + theta(kOscGain) * (u + theta(kOscInputOffset));
  a.dy = -theta(kOscStiffness);
  a.dv = -theta(kOscDamping);
  for (std::size_t i = 0; i < s.terms.size(); ++i) {
    const OscillatorTermValue t = oscillator_term(s.terms[i], y, v);
    const double c = theta(s.term_index(i));
    phi[i] = t.value;
    a.value -= c * t.value;
    a.dy -= c * t.dy;
    a.dv -= c * t.dv;
  }
  return a;
}

}  // namespace

const char* oscillator_term_name(OscillatorTerm term) {
  switch (term) {
    case OscillatorTerm::y2: return "y2";
    case OscillatorTerm::y3: return "y3";
    case OscillatorTerm::y_abs_y: return "y_abs_y";
    case OscillatorTerm::v_log_v: return "v_log_v";
    case OscillatorTerm::y_v: return "y_v";
    case OscillatorTerm::v2: return "v2";
    case OscillatorTerm::y_v2: return "y_v2";
    case OscillatorTerm::v_y2: return "v_y2";
  }
  return "?";
}

OscillatorTerm oscillator_term_from_name(const std::string& name) {
  for (OscillatorTerm t : kAllTerms) {
    if (name == oscillator_term_name(t)) return t;
  }
  throw std::invalid_argument("unknown oscillator term \"" + name + "\" (" + term_names() + ")");
}

OscillatorTermValue oscillator_term(OscillatorTerm term, double y, double v) {
  switch (term) {
    case OscillatorTerm::y2: return {y * y, 2 * y, 0.0};
    case OscillatorTerm::y3: return {y * y * y, 3 * y * y, 0.0};
    case OscillatorTerm::y_abs_y: return {y * std::abs(y), 2 * std::abs(y), 0.0};
    case OscillatorTerm::v_log_v: {
      const double square = v * v + 1e-30;
      return {0.5 * v * std::log(square), 0.0, 0.5 * std::log(square) + v * v / square};
    }
    case OscillatorTerm::y_v: return {y * v, v, y};
    case OscillatorTerm::v2: return {v * v, 0.0, 2 * v};
    case OscillatorTerm::y_v2: return {y * v * v, v * v, 2 * y * v};
    case OscillatorTerm::v_y2: return {v * y * y, 2 * v * y, y * y};
  }
  return {};
}

Eigen::Index OscillatorStructure::parameter_count() const {
  return kOscFixedParameters + static_cast<Eigen::Index>(terms.size()) + output_taps + input_taps;
}
Eigen::Index OscillatorStructure::term_index(std::size_t i) const {
  return kOscFixedParameters + static_cast<Eigen::Index>(i);
}
Eigen::Index OscillatorStructure::output_tap_index() const {
  return kOscFixedParameters + static_cast<Eigen::Index>(terms.size());
}
Eigen::Index OscillatorStructure::input_tap_index() const { return output_tap_index() + output_taps; }

void OscillatorStructure::check() const {
  if (substeps < 1 || substeps > 64) throw std::invalid_argument("substeps must be 1-64, got " + std::to_string(substeps));
  if (output_taps < 0 || output_taps > 64) {
    throw std::invalid_argument("output taps must be 0-64, got " + std::to_string(output_taps));
  }
  if (input_taps < 0 || input_taps > 64) throw std::invalid_argument("input taps must be 0-64, got " + std::to_string(input_taps));
  for (std::size_t i = 0; i < terms.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (terms[i] == terms[j]) throw std::invalid_argument(std::string("the term ") + oscillator_term_name(terms[i]) + " is given twice");
    }
  }
}

OscillatorRun oscillator_run(const OscillatorStructure& s, const Eigen::VectorXd& theta, const BandLimitedInput& input,
                             const Eigen::Vector2d& x0, OscillatorSensitivity which, Eigen::Index samples) {
  const Eigen::VectorXd& u = input.samples();
  const Eigen::Index n = samples < 0 ? u.size() : std::min(samples, u.size());
  const Eigen::Index terms = static_cast<Eigen::Index>(s.terms.size());
  const Eigen::Index columns = which == OscillatorSensitivity::all ? 2 + theta.size()
                               : which == OscillatorSensitivity::initial_state ? 2 : 0;
  OscillatorRun run;
  Eigen::VectorXd displacement = Eigen::VectorXd::Zero(n);  // y[k], the oscillator's own
  Eigen::MatrixXd displacement_sensitivity = Eigen::MatrixXd::Zero(n, columns);  // ∂y[k]/∂[x(0); θ]

  // The state (y, v) and its sensitivity S = ∂(y, v)/∂[x(0); θ] (2 × columns), S(0) = [I 0].
  double y = x0(0), v = x0(1);
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(2, columns);
  if (columns > 0) S.leftCols(2).setIdentity();
  // One RK4 stage's slope k_i = f(x_i) and its derivative dk_i = F_x·dx_i + F_θ, dx_i = S + h·α_i·dk_{i−1}.
  Eigen::MatrixXd dk[4], stage_S(2, columns);
  for (auto& m : dk) m.setZero(2, columns);
  std::vector<double> phi(s.terms.size());
  const double h = 1.0 / s.substeps, delay = theta(kOscDelay), g = theta(kOscGain);
  const double stage_offset[4] = {0.0, 0.5, 0.5, 1.0};  // α_i: where stage i sits in the step, and how far it leans
  for (Eigen::Index k = 0; k < n; ++k) {
    displacement(k) = y;
    if (columns > 0) displacement_sensitivity.row(k) = S.row(0);
    if (k == n - 1) break;
    for (int j = 0; j < s.substeps; ++j) {
      const double t = static_cast<double>(k) + j * h - delay;
      double slope_y[4], slope_v[4];
      for (int i = 0; i < 4; ++i) {
        const double lean = h * stage_offset[i];
        const double yi = i == 0 ? y : y + lean * slope_y[i - 1];
        const double vi = i == 0 ? v : v + lean * slope_v[i - 1];
        const double ui = input.value(t + lean);
        const Acceleration a = acceleration(s, theta, yi, vi, ui, phi.data());
        slope_y[i] = vi;
        slope_v[i] = a.value;
        if (columns == 0) continue;
        // The exact derivative of RK4's stage: dk_i = F_x(x_i)·(S + h·α_i·dk_{i−1}) + F_θ(x_i).
        if (i == 0) {
          stage_S = S;
        } else {
          stage_S = S + lean * dk[i - 1];
        }
        dk[i].row(0) = stage_S.row(1);
        dk[i].row(1) = a.dy * stage_S.row(0) + a.dv * stage_S.row(1);
        if (which == OscillatorSensitivity::all) {
          dk[i](1, 2 + kOscDamping) -= vi;
          dk[i](1, 2 + kOscStiffness) -= yi;
          dk[i](1, 2 + kOscGain) += ui + theta(kOscInputOffset);
          dk[i](1, 2 + kOscInputOffset) += g;
          dk[i](1, 2 + kOscDelay) -= g * input.slope(t + lean);
          for (Eigen::Index c = 0; c < terms; ++c) dk[i](1, 2 + s.term_index(static_cast<std::size_t>(c))) -= phi[c];
        }
      }
      y += h / 6 * (slope_y[0] + 2 * slope_y[1] + 2 * slope_y[2] + slope_y[3]);
      v += h / 6 * (slope_v[0] + 2 * slope_v[1] + 2 * slope_v[2] + slope_v[3]);
      if (columns > 0) S += h / 6 * (dk[0] + 2 * dk[1] + 2 * dk[2] + dk[3]);
    }
    if (!(std::abs(y) <= kOscillatorBound && std::abs(v) <= kOscillatorBound)) {
      run.diverged = k + 1;
      break;
    }
  }

  // The sampled output: the output filter (gain 1 at DC), the input taps and the offset.
  const Eigen::Index out0 = s.output_tap_index(), in0 = s.input_tap_index();
  auto past = [](const Eigen::VectorXd& x, Eigen::Index k, Eigen::Index i) { return x(std::max<Eigen::Index>(0, k - i)); };
  const double taps_sum = theta.segment(out0, s.output_taps).sum();
  run.y.resize(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    double out = (1.0 - taps_sum) * displacement(k) + theta(kOscOutputOffset);
    for (int i = 1; i <= s.output_taps; ++i) out += theta(out0 + i - 1) * past(displacement, k, i);
    for (int i = 0; i < s.input_taps; ++i) out += theta(in0 + i) * past(u, k, i);
    run.y(k) = out;
  }
  if (columns == 0) return run;
  run.jacobian = (1.0 - taps_sum) * displacement_sensitivity;
  for (int i = 1; i <= s.output_taps; ++i) {
    const double tap = theta(out0 + i - 1);
    for (Eigen::Index k = 0; k < n; ++k) run.jacobian.row(k) += tap * displacement_sensitivity.row(std::max<Eigen::Index>(0, k - i));
  }
  if (which == OscillatorSensitivity::all) {
    run.jacobian.col(2 + kOscOutputOffset).setOnes();
    for (Eigen::Index k = 0; k < n; ++k) {
      for (int i = 1; i <= s.output_taps; ++i) run.jacobian(k, 2 + out0 + i - 1) = past(displacement, k, i) - displacement(k);
      for (int i = 0; i < s.input_taps; ++i) run.jacobian(k, 2 + in0 + i) = past(u, k, i);
    }
  }
  return run;
}

Eigen::Vector2d oscillator_initial_state(const OscillatorStructure& s, const Eigen::VectorXd& theta,
                                         const BandLimitedInput& input, const Eigen::VectorXd& y, Eigen::Index init) {
  init = std::min({init, y.size(), input.samples().size()});
  Eigen::Vector2d x0 = Eigen::Vector2d::Zero();
  if (init <= 0) return x0;
  // Start from the first output as the displacement, at rest.
  x0(0) = y(0) - theta(kOscOutputOffset);
  auto loss = [&](const Eigen::VectorXd& x) {
    const OscillatorRun r = oscillator_run(s, theta, input, x, OscillatorSensitivity::none, init);
    if (r.diverged) return std::numeric_limits<double>::infinity();
    return (r.y - y.head(init)).squaredNorm();
  };
  LmSettings settings;
  settings.damping = LmDamping::relative_to_largest;
  LevenbergMarquardt lm(settings, 2);
  Eigen::VectorXd x = x0;
  for (int iteration = 0; iteration < 50; ++iteration) {
    const OscillatorRun r = oscillator_run(s, theta, input, x, OscillatorSensitivity::initial_state, init);
    if (r.diverged) break;
    const Eigen::VectorXd e = r.y - y.head(init);
    const double V = e.squaredNorm();
    const Eigen::MatrixXd H = r.jacobian.transpose() * r.jacobian;
    const Eigen::VectorXd gradient = r.jacobian.transpose() * e;
    const LmStep step = lm.step(H, gradient, V, x, loss);
    if (!step.accepted || V - step.loss <= 1e-12 * V) break;
  }
  return x;
}

Eigen::VectorXd OscillatorModel::simulate_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) const {
  if (u.size() == 0) return {};
  return simulate_scaled(BandLimitedInput(u), y, init);
}

Eigen::VectorXd OscillatorModel::simulate_scaled(const BandLimitedInput& input, const Eigen::VectorXd& y, Eigen::Index init) const {
  const Eigen::Index n = input.samples().size();
  if (init > 0 && y.size() < std::min(init, n)) {
    throw std::invalid_argument("oscillator: " + std::to_string(init) + " measured outputs set the state, " +
                                std::to_string(y.size()) + " given");
  }
  Eigen::VectorXd out = run_from_fitted_state(input, y, init);
  const Eigen::Index measured = std::min({init, n, y.size()});
  if (measured > 0) out.head(measured) = y.head(measured);
  return out;
}

Eigen::VectorXd OscillatorModel::run_from_fitted_state(const BandLimitedInput& input, const Eigen::VectorXd& y,
                                                       Eigen::Index init) const {
  const Eigen::Vector2d x0 = oscillator_initial_state(structure, theta, input, y, init);
  OscillatorRun run = oscillator_run(structure, theta, input, x0, OscillatorSensitivity::none);
  if (run.diverged) {
    throw std::runtime_error("oscillator: the free run diverged at sample " + std::to_string(*run.diverged) +
                             " (its state beyond ±" + std::to_string(kOscillatorBound) + " in scaled units)");
  }
  return std::move(run.y);
}

Eigen::VectorXd OscillatorModel::simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) const {
  const Eigen::VectorXd y_scaled = y.size() ? scaling.scale_y(y) : Eigen::VectorXd();
  return scaling.unscale_y(simulate_scaled(scaling.scale_u(u), y_scaled, init));
}

Eigen::VectorXd OscillatorModel::predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const {
  const Eigen::Index init = std::min({kPredictorInit, u.size(), y.size()});
  return scaling.unscale_y(run_from_fitted_state(BandLimitedInput(scaling.scale_u(u)), scaling.scale_y(y), init));
}

nlohmann::json oscillator_model_to_json(const OscillatorModel& m) {
  const OscillatorStructure& s = m.structure;
  nlohmann::json terms = nlohmann::json::array();
  for (std::size_t i = 0; i < s.terms.size(); ++i) {
    terms.push_back({{"term", oscillator_term_name(s.terms[i])}, {"coefficient", m.theta(s.term_index(i))}});
  }
  return {{"format", kModelFormat},
          {"kind", kOscillatorKind},
          {"fs", m.fs},
          {"scaling", scaling_to_json(m.scaling)},
          {"params",
           {{"substeps", s.substeps},
            {"damping", m.theta(kOscDamping)},
            {"stiffness", m.theta(kOscStiffness)},
            {"gain", m.theta(kOscGain)},
            {"input_offset", m.theta(kOscInputOffset)},
            {"output_offset", m.theta(kOscOutputOffset)},
            {"delay", m.theta(kOscDelay)},
            {"terms", terms},
            {"output_fir", to_array(m.theta.segment(s.output_tap_index(), s.output_taps))},
            {"input_fir", to_array(m.theta.segment(s.input_tap_index(), s.input_taps))}}},
          {"meta", m.meta.is_null() ? nlohmann::json::object() : m.meta}};
}

OscillatorModel oscillator_model_from_json(const nlohmann::json& j) {
  JsonFields top(j, "model");
  OscillatorModel m;
  m.fs = read_model_header(top, kOscillatorKind);
  m.scaling = read_model_scaling(top);
  JsonFields p(read_model_params(top), "model.params");
  OscillatorStructure& s = m.structure;
  s.substeps = static_cast<int>(p.integer("substeps", 4, 1, 64));
  std::vector<double> coefficients;
  if (const nlohmann::json* terms = p.member("terms")) {
    if (!terms->is_array()) throw ConfigError(p.path_of("terms") + ": expected an array of {\"term\", \"coefficient\"}");
    for (std::size_t i = 0; i < terms->size(); ++i) {
      JsonFields t((*terms)[i], p.path_of("terms") + "[" + std::to_string(i) + "]");
      try {
        s.terms.push_back(oscillator_term_from_name(t.string("term", "")));
      } catch (const std::invalid_argument& e) {
        throw ConfigError(t.path_of("term") + ": " + e.what());
      }
      coefficients.push_back(t.number("coefficient"));
      t.finish();
    }
  }
  auto fir = [&](const char* key) {
    const nlohmann::json* taps = p.member(key);
    return taps == nullptr ? Eigen::VectorXd() : read_vector(*taps, p.path_of(key));
  };
  const Eigen::VectorXd output_fir = fir("output_fir"), input_fir = fir("input_fir");
  s.output_taps = static_cast<int>(output_fir.size());
  s.input_taps = static_cast<int>(input_fir.size());
  try {
    s.check();
  } catch (const std::invalid_argument& e) {
    throw ConfigError("model.params: " + std::string(e.what()));
  }
  m.theta = Eigen::VectorXd::Zero(s.parameter_count());
  m.theta(kOscDamping) = p.number("damping");
  m.theta(kOscStiffness) = p.number("stiffness");
  m.theta(kOscGain) = p.number("gain");
  m.theta(kOscInputOffset) = p.number("input_offset", 0.0);
  m.theta(kOscOutputOffset) = p.number("output_offset", 0.0);
  m.theta(kOscDelay) = p.number("delay", 0.0);
  require_within(m.theta(kOscDelay), -64.0, 64.0, p.path_of("delay"));
  for (std::size_t i = 0; i < coefficients.size(); ++i) m.theta(s.term_index(i)) = coefficients[i];
  m.theta.segment(s.output_tap_index(), s.output_taps) = output_fir;
  m.theta.segment(s.input_tap_index(), s.input_taps) = input_fir;
  p.finish();
  m.meta = read_model_meta(top);
  top.finish();
  const OscillatorRun run = oscillator_run(s, m.theta, BandLimitedInput(free_run_drive()), Eigen::Vector2d::Zero(),
                                           OscillatorSensitivity::none);
  const std::optional<Runaway> away = run.diverged ? Runaway{*run.diverged, NAN} : runaway(run.y);
  if (away) {
    throw ConfigError("model.params: the oscillator's free run on full-scale noise leaves ±" + std::to_string(kFreeRunBound) +
                      " (scaled units) after " + std::to_string(away->samples) + " samples: not a usable model");
  }
  return m;
}

}  // namespace panelbass::models

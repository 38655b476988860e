#include "models/oscillator/oscillator_fit.h"

#include <chrono>
#include <cmath>
#include <complex>
#include <optional>
#include <stdexcept>

#include "models/optimization/least_squares.h"
#include "models/optimization/levenberg_marquardt.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

/// d, k and g of the continuous-time oscillator whose sampled poles are those of the ARX(2, 2) model of
/// (u, y) (scaled): z² + a₁z + a₂ = 0, s = ln z, d = −(s₁ + s₂), k = s₁·s₂, and g = k times the DC gain.
void linear_start(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::VectorXd& theta) {
  const Eigen::Index n = y.size();
  Eigen::MatrixXd phi(n - 2, 5);
  for (Eigen::Index k = 2; k < n; ++k) phi.row(k - 2) << -y(k - 1), -y(k - 2), u(k - 1), u(k - 2), 1.0;
  const Eigen::VectorXd arx = least_squares(phi, y.tail(n - 2)).theta;
  const double a1 = arx(0), a2 = arx(1);
  const std::complex<double> root = std::sqrt(std::complex<double>(a1 * a1 - 4 * a2));
  const std::complex<double> z1 = (-a1 + root) / 2.0, z2 = (-a1 - root) / 2.0;
  auto not_a_damped_pole = [](std::complex<double> z) {
    return std::abs(z) >= 1.0 || (std::abs(z.imag()) < 1e-12 && z.real() <= 0.0);
  };
  if (not_a_damped_pole(z1) || not_a_damped_pole(z2)) {
    throw std::invalid_argument("the data's ARX(2,2) model has poles " + std::to_string(z1.real()) + (z1.imag() < 0 ? "" : "+") +
                                std::to_string(z1.imag()) + "j and " + std::to_string(z2.real()) + (z2.imag() < 0 ? "" : "+") +
                                std::to_string(z2.imag()) + "j: not a damped oscillator sampled fast enough to start from");
  }
  const std::complex<double> s1 = std::log(z1), s2 = std::log(z2);
  theta(kOscDamping) = -(s1 + s2).real();
  theta(kOscStiffness) = (s1 * s2).real();
  theta(kOscGain) = (arx(2) + arx(3)) / (1.0 + a1 + a2) * theta(kOscStiffness);
}

/// The parameters a stage frees: x(0) (columns 0, 1), the linear oscillator, and as `stage` says the terms
/// up to it, the delay and the taps. Columns of the run's Jacobian ([x(0); θ]).
std::vector<Eigen::Index> free_columns(const OscillatorStructure& s, std::size_t terms, bool delay, bool taps) {
  std::vector<Eigen::Index> free = {0, 1, 2 + kOscDamping, 2 + kOscStiffness, 2 + kOscGain, 2 + kOscInputOffset,
                                    2 + kOscOutputOffset};
  if (delay) free.push_back(2 + kOscDelay);
  for (std::size_t i = 0; i < terms; ++i) free.push_back(2 + s.term_index(i));
  if (taps) {
    for (Eigen::Index i = 0; i < s.output_taps + s.input_taps; ++i) free.push_back(2 + s.output_tap_index() + i);
  }
  return free;
}

/// The model of `s`'s first `terms` terms (and its taps when `taps`) holding those entries of θ.
OscillatorModel trimmed(const OscillatorStructure& s, const Eigen::VectorXd& theta, std::size_t terms, bool taps) {
  OscillatorModel m;
  m.structure = s;
  m.structure.terms.resize(terms);
  if (!taps) m.structure.output_taps = m.structure.input_taps = 0;
  m.theta = Eigen::VectorXd::Zero(m.structure.parameter_count());
  m.theta.head(kOscFixedParameters) = theta.head(kOscFixedParameters);
  for (std::size_t i = 0; i < terms; ++i) m.theta(m.structure.term_index(i)) = theta(s.term_index(i));
  const Eigen::Index taps_count = m.structure.output_taps + m.structure.input_taps;
  m.theta.segment(m.structure.output_tap_index(), taps_count) = theta.segment(s.output_tap_index(), taps_count);
  return m;
}

}  // namespace

OscillatorFit fit_oscillator(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const Eigen::VectorXd& u_val,
                             const Eigen::VectorXd& y_val, double fs, const OscillatorFitOptions& options) {
  const OscillatorStructure& s = options.structure;
  s.check();
  if (u.size() != y.size() || u_val.size() != y_val.size()) {
    throw std::invalid_argument("oscillator fit: the input and output of a record differ in length");
  }
  const Eigen::Index shortest = 4 * (options.init + 10);
  if (y.size() < shortest || (y_val.size() > 0 && y_val.size() < shortest)) {
    throw std::invalid_argument("oscillator fit: a record of " + std::to_string(std::min(y.size(), y_val.size() ? y_val.size() : y.size())) +
                                " samples; at least " + std::to_string(shortest) + " (4 × (init + 10)) are needed");
  }
  const auto began = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count(); };

  OscillatorFit fit;
  const Scaling scaling = scaling_from_data(u, y);
  const Eigen::VectorXd us = scaling.scale_u(u), ys = scaling.scale_y(y);
  const BandLimitedInput input(us);
  const std::optional<BandLimitedInput> input_val =
      u_val.size() ? std::optional<BandLimitedInput>(scaling.scale_u(u_val)) : std::nullopt;
  const Eigen::Index P = s.parameter_count();
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(P);
  linear_start(us, ys, theta);
  Eigen::VectorXd x0(2);
  x0 << ys(0), ys(1) - ys(0);

  // The stages: linear, each term, the taps.
  struct Plan {
    std::string name;
    std::size_t terms;
    bool delay, taps;
  };
  std::vector<Plan> plans = {{"linear", 0, false, false}};
  for (std::size_t i = 0; i < s.terms.size(); ++i) plans.push_back({oscillator_term_name(s.terms[i]), i + 1, options.delay, false});
  if (s.output_taps + s.input_taps > 0) plans.push_back({"taps", s.terms.size(), options.delay, true});

  LmSettings settings;
  settings.damping = LmDamping::relative_to_largest;
  double best_j = std::numeric_limits<double>::infinity();
  bool stopped = false;
  for (const Plan& plan : plans) {
    const std::vector<Eigen::Index> free = free_columns(s, plan.terms, plan.delay, plan.taps);
    const Eigen::Index F = static_cast<Eigen::Index>(free.size());
    Eigen::VectorXd all(2 + P), reduced(F);
    auto spread = [&](const Eigen::VectorXd& r) {  // a reduced vector back into [x(0); θ]
      Eigen::VectorXd full = all;
      for (Eigen::Index i = 0; i < F; ++i) full(free[static_cast<std::size_t>(i)]) = r(i);
      return full;
    };
    auto loss = [&](const Eigen::VectorXd& r) {
      const Eigen::VectorXd full = spread(r);
      const OscillatorRun run = oscillator_run(s, full.tail(P), input, full.head(2), OscillatorSensitivity::none);
      return run.diverged ? std::numeric_limits<double>::infinity() : (run.y - ys).squaredNorm();
    };
    all << x0, theta;
    for (Eigen::Index i = 0; i < F; ++i) reduced(i) = all(free[static_cast<std::size_t>(i)]);
    LevenbergMarquardt lm(settings, F);
    OscillatorStage stage;
    stage.name = plan.name;
    for (int iteration = 0; iteration < options.max_iterations && !stopped; ++iteration) {
      const OscillatorRun run = oscillator_run(s, theta, input, x0, OscillatorSensitivity::all);
      if (run.diverged) break;
      const Eigen::VectorXd e = run.y - ys;
      Eigen::MatrixXd J(run.jacobian.rows(), F);
      for (Eigen::Index i = 0; i < F; ++i) J.col(i) = run.jacobian.col(free[static_cast<std::size_t>(i)]);
      Eigen::MatrixXd H = Eigen::MatrixXd::Zero(F, F);
      H.selfadjointView<Eigen::Lower>().rankUpdate(J.transpose());
      H.triangularView<Eigen::StrictlyUpper>() = H.transpose();
      const double V = e.squaredNorm();
      const LmStep step = lm.step(H, J.transpose() * e, V, reduced, loss);
      if (step.accepted) {
        ++stage.iterations;
        all = spread(reduced);
        x0 = all.head(2);
        theta = all.tail(P);
      }
      if (options.progress) {
        OscillatorFitProgress progress{plan.name, fit.stages.size(), plans.size(), iteration + 1,
                                       100.0 * step.loss / ys.squaredNorm()};
        stopped = !options.progress(progress);
      }
      if (!step.accepted || V - step.loss <= 1e-9 * V) break;
    }
    OscillatorModel model = trimmed(s, theta, plan.terms, plan.taps);
    model.scaling = scaling;
    model.fs = fs;
    auto protocol_j = [&](const BandLimitedInput& in, const Eigen::VectorXd& yy) {  // as validate reports it
      try {
        return j_percent(scaling.unscale_y(model.simulate_scaled(in, scaling.scale_y(yy), options.init)), yy, options.init);
      } catch (const std::runtime_error&) {
        return std::numeric_limits<double>::infinity();  // diverged on this record
      }
    };
    stage.j_est_pct = protocol_j(input, y);
    stage.j_val_pct = input_val ? protocol_j(*input_val, y_val) : std::nan("");
    stage.seconds = seconds();
    fit.stages.push_back(stage);
    const double j = u_val.size() ? stage.j_val_pct : stage.j_est_pct;
    if (j < best_j) {
      best_j = j;
      fit.best_stage = fit.stages.size() - 1;
      fit.model = model;
    }
    if (stopped) break;
  }
  if (!std::isfinite(best_j)) throw std::runtime_error("oscillator fit: every stage's model diverged on the records");
  return fit;
}

}  // namespace panelbass::models

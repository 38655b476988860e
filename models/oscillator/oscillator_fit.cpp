#include "models/oscillator/oscillator_fit.h"

#include <chrono>
#include <cmath>
#include <complex>
#include <optional>
#include <stdexcept>

#include "models/linear/transfer_function.h"
#include "models/optimization/least_squares.h"
#include "models/optimization/levenberg_marquardt.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

/// The ARX(n, n) model (with a constant) of (u, y) as a transfer function.
TransferFunction arx(const Eigen::VectorXd& u, const Eigen::VectorXd& y, int n) {
  const Eigen::Index rows = y.size() - n;
  Eigen::MatrixXd phi(rows, 2 * n + 1);
  for (Eigen::Index k = n; k < y.size(); ++k) {
    for (int i = 1; i <= n; ++i) {
      phi(k - n, i - 1) = -y(k - i);
      phi(k - n, n + i - 1) = u(k - i);
    }
    phi(k - n, 2 * n) = 1.0;
  }
  const Eigen::VectorXd theta = least_squares(phi, y.tail(rows)).theta;
  TransferFunction tf;
  tf.a = theta.head(n);
  tf.b = theta.segment(n, n);
  tf.nk = 1;
  return tf;
}

/// d, k and g of the linear oscillator to start from: the resonance of the data's ARX(n, n) model for the
/// lowest n = 2 … 8 that has one — its complex pole pair of the largest radius inside the unit circle (or, for
/// n = 2, two positive real poles inside it) — mapped to continuous time (s = ln z: d = −(s₁ + s₂), k = s₁·s₂),
/// and g = k times the model's DC gain. ARX(2, 2) is the oscillator's own sampled form; a transducer with more
/// dynamics (a coil's inductance, a sensor's filter) needs more poles around its resonance.
void linear_start(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Ref<Eigen::VectorXd> theta) {
  std::string seen;
  for (int n = 2; n <= 8; ++n) {
    const TransferFunction tf = arx(u, y, n);
    const Eigen::VectorXcd poles = tf.poles();
    std::complex<double> z1, z2;
    bool found = false;
    for (Eigen::Index i = 0; i < poles.size(); ++i) {
      const std::complex<double> z = poles(i);
      if (z.imag() > 1e-9 && std::abs(z) < 1.0 && (!found || std::abs(z) > std::abs(z1))) found = true, z1 = z, z2 = std::conj(z);
    }
    const bool real_pair = n == 2 && poles.imag().cwiseAbs().maxCoeff() < 1e-12 && poles.real().minCoeff() > 0.0 &&
                           poles.real().maxCoeff() < 1.0;
    if (!found && real_pair) found = true, z1 = poles(0), z2 = poles(1);  // an overdamped oscillator
    if (!found) {
      seen += std::string(seen.empty() ? "" : ", ") + "ARX(" + std::to_string(n) + "," + std::to_string(n) + ")";
      continue;
    }
    const std::complex<double> s1 = std::log(z1), s2 = std::log(z2);
    theta(kOscDamping) = -(s1 + s2).real();
    theta(kOscStiffness) = (s1 * s2).real();
    theta(kOscGain) = tf.b.sum() / (1.0 + tf.a.sum()) * theta(kOscStiffness);
    return;
  }
  throw std::invalid_argument("no resonance to start from: the data's " + seen +
                              " models have no complex pole pair inside the unit circle (nor ARX(2,2) two positive "
                              "real poles), so it does not look like a damped oscillator sampled fast enough");
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
  // p = [x(0); θ], the columns of the run's Jacobian.
  const Eigen::Index P = s.parameter_count();
  Eigen::VectorXd p = Eigen::VectorXd::Zero(2 + P);
  p.head(2) << ys(0), ys(1) - ys(0);
  linear_start(us, ys, p.tail(P));

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
    Eigen::VectorXd reduced(F);
    auto spread = [&](const Eigen::VectorXd& r) {  // a reduced vector back into [x(0); θ]
      Eigen::VectorXd full = p;
      for (Eigen::Index i = 0; i < F; ++i) full(free[static_cast<std::size_t>(i)]) = r(i);
      return full;
    };
    auto loss = [&](const Eigen::VectorXd& r) {
      const Eigen::VectorXd full = spread(r);
      const OscillatorRun run = oscillator_run(s, full.tail(P), input, full.head(2), OscillatorSensitivity::none);
      return run.diverged ? std::numeric_limits<double>::infinity() : (run.y - ys).squaredNorm();
    };
    for (Eigen::Index i = 0; i < F; ++i) reduced(i) = p(free[static_cast<std::size_t>(i)]);
    LevenbergMarquardt lm(settings, F);
    OscillatorStage stage;
    stage.name = plan.name;
    for (int iteration = 0; iteration < options.max_iterations && !stopped; ++iteration) {
      const OscillatorRun run = oscillator_run(s, p.tail(P), input, p.head(2), OscillatorSensitivity::all);
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
        p = spread(reduced);
      }
      if (options.progress) {
        OscillatorFitProgress progress{plan.name, fit.stages.size(), plans.size(), iteration + 1,
                                       j_ratio_percent(step.loss, ys.squaredNorm(), "the scaled output")};
        stopped = !options.progress(progress);
      }
      if (!step.accepted || V - step.loss <= 1e-9 * V) break;
    }
    OscillatorModel model = trimmed(s, p.tail(P), plan.terms, plan.taps);
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

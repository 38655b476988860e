#include "models/control/mirror_friction_refit.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>
#include <string>

#include "dsp/harmonics.h"
#include "models/control/mirror_current_fit.h"
#include "models/optimization/levenberg_marquardt.h"

namespace panelbass::models {
namespace {

constexpr int kHighestHarmonic = 5;
constexpr double kGridHalfWidth = 1.5;  // log(v0 scale) searched within ±1.5: ×/÷ 4.5

/// log(v0's scale) held within twice the grid's reach (×/÷ 20): where the harmonics do not depend on v0 (a transducer
/// whose friction the quiet sines do not show) the step would otherwise walk θ off to an infinite scale.
double bounded_log_scale(double theta) { return std::clamp(theta, -2.0 * kGridHalfWidth, 2.0 * kGridHalfWidth); }
constexpr double kGridStep = 0.1;
constexpr double kRequiredGain = 0.01;  // the refit is used when it lowers the error by 1 %

// The eddy-current branch's search (search_eddy_branch): the rates ρ = h·R2/L2 tried (a slower branch, ρ < 1, made
// every plant's harmonics worse; panel-exciter-l2r2's is 2.1, second-exciter's 2.2), r_b/e_R from 0.3 doubled up to 1.2
// (the two plants' R2/Re: 0.63, 0.65), Levenberg–Marquardt steps of each refit (warm-started by add_eddy_branch, the
// linear drive path already right), and the harmonic error's cut a branch must make to be used: on the plants without
// a branch the best branch tried cut it by 3 % at most (panel-exciter-le-i) and raised it on the rest; on the two with
// one it cut it by 74 % and 26 % (docs/control.md).
constexpr double kEddyRates[] = {1.5, 3.0, 6.0};
constexpr double kEddySmallestRatio = 0.3, kEddyLargestRatio = 1.2;
constexpr int kEddyRefitIterations = 5;
constexpr double kEddyRequiredGain = 0.2;
// ... and the share of the harmonics' own power its error may leave at most: a branch that cuts the error of a model
// far off the sines absorbs what else is off (second-exciter through the card: the model without a branch left 30 %
// of the harmonics' power, the branch chosen 20 %, and the 80 Hz cut at 0.1 fell 8.4 → 1.5 dB); the models with a
// working filter leave 0.06–1.6 % (with a branch 0.06–0.2 %)
constexpr double kEddyLargestErrorShare = 0.02;

std::vector<std::complex<double>> relative_harmonics(const Eigen::VectorXd& current, const dsp::SineStep& step, double fs) {
  const auto first = static_cast<Eigen::Index>(step.measure_start), length = static_cast<Eigen::Index>(step.measure_length);
  const dsp::HarmonicLevels levels = dsp::harmonic_levels(current.segment(first, length), fs, step.frequency, kHighestHarmonic);
  std::vector<std::complex<double>> out;
  for (std::size_t h = 2; h <= levels.amplitude.size(); ++h) out.push_back(levels.relative(h));
  return out;
}

/// The record checked, and its relative harmonics per step.
std::vector<std::vector<std::complex<double>>> record_harmonics(const CurrentSineRecord& r, double fs) {
  if (r.steps.empty()) throw std::invalid_argument("friction refit: no sine to fit to");
  if (r.drive.size() != r.current.size()) {
    throw std::invalid_argument("friction refit: drive and current differ in length (" + std::to_string(r.drive.size()) +
                                ", " + std::to_string(r.current.size()) + ")");
  }
  if (!r.drive.allFinite() || !r.current.allFinite()) throw std::invalid_argument("friction refit: a sample is not finite");
  std::vector<std::vector<std::complex<double>>> out;
  for (std::size_t k = 0; k < r.steps.size(); ++k) {
    const dsp::SineStep& step = r.steps[k];
    const std::string where = "friction refit: step " + std::to_string(k) + " (" + std::to_string(step.frequency) + " Hz): ";
    if (!(step.frequency > 0.0 && 2.0 * step.frequency < fs / 2.0)) throw std::invalid_argument(where + "its second harmonic must be below fs/2");
    if (step.measure_start + step.measure_length > static_cast<std::size_t>(r.current.size())) {
      throw std::invalid_argument(where + "its measured part ends after the record");
    }
    if (static_cast<double>(step.measure_length) * step.frequency / fs < 4.0) throw std::invalid_argument(where + "under 4 periods measured");
    const Eigen::VectorXd part = r.current.segment(static_cast<Eigen::Index>(step.measure_start), static_cast<Eigen::Index>(step.measure_length));
    if (!(dsp::harmonic_levels(part, fs, step.frequency, 1).amplitude[0] > 0.0)) throw std::invalid_argument(where + "the current has no fundamental");
    out.push_back(relative_harmonics(r.current, step, fs));
  }
  return out;
}

/// The residual at log(v0 scale) = θ: the model's relative harmonics minus the record's, real and imaginary parts,
/// the model run from rest over the whole record with its drive `lag` samples late. Empty when it leaves the finite.
Eigen::VectorXd harmonic_residual(const MirrorModel& model, int lag, const CurrentSineRecord& r,
                                  const std::vector<std::vector<std::complex<double>>>& target, double fs, double theta) {
  MirrorModel m = model;
  m.friction_velocity *= std::exp(bounded_log_scale(theta));
  const Eigen::VectorXd current = run_mirror_model(m, r.drive, lag).i;
  if (!current.allFinite()) return {};
  std::vector<double> out;
  for (std::size_t k = 0; k < r.steps.size(); ++k) {
    const std::vector<std::complex<double>> h = relative_harmonics(current, r.steps[k], fs);
    for (std::size_t j = 0; j < target[k].size() && j < h.size(); ++j) {
      out.push_back(h[j].real() - target[k][j].real());
      out.push_back(h[j].imag() - target[k][j].imag());
    }
  }
  const Eigen::VectorXd v = Eigen::Map<const Eigen::VectorXd>(out.data(), static_cast<Eigen::Index>(out.size()));
  return v.allFinite() ? v : Eigen::VectorXd();
}

double loss_of(const Eigen::VectorXd& r) {
  return r.size() == 0 ? std::numeric_limits<double>::infinity() : r.squaredNorm();
}

}  // namespace

FrictionScaleRefit refit_friction_scale(const MirrorModel& model, int current_lag, const CurrentSineRecord& record, double fs) {
  const std::vector<std::vector<std::complex<double>>> target = record_harmonics(record, fs);
  double power = 0.0;
  std::size_t count = 0;
  for (const auto& step : target) {
    for (const std::complex<double>& h : step) {
      power += std::norm(h);
      ++count;
    }
  }
  FrictionScaleRefit out;
  out.model = model;
  out.harmonics_rms = count > 0 ? std::sqrt(power / static_cast<double>(count)) : 0.0;
  const auto residual = [&](double theta) { return harmonic_residual(model, current_lag, record, target, fs, theta); };
  out.error_before = loss_of(residual(0.0));
  out.error_after = out.error_before;
  if (!std::isfinite(out.error_before)) throw std::invalid_argument("friction refit: the model leaves the finite on the sines");
  // the grid
  double theta = 0.0, best = out.error_before;
  const int half = static_cast<int>(std::lround(kGridHalfWidth / kGridStep));
  for (int g = -half; g <= half; ++g) {
    const double t = g * kGridStep;
    const double loss = loss_of(residual(t));
    if (loss < best) {
      best = loss;
      theta = t;
    }
  }
  // Levenberg–Marquardt from there, dV/dθ by a central difference of the residual
  LmSettings settings;
  settings.damping = LmDamping::relative_to_largest;
  LevenbergMarquardt lm(settings, 1);
  Eigen::VectorXd th(1);
  th[0] = theta;
  Eigen::VectorXd r = residual(theta);
  for (int step = 0; step < 30 && r.size() > 0; ++step) {
    constexpr double kDelta = 1e-4;
    const Eigen::VectorXd up = residual(th[0] + kDelta), down = residual(th[0] - kDelta);
    if (up.size() != r.size() || down.size() != r.size()) break;
    const Eigen::VectorXd jacobian = (up - down) / (2.0 * kDelta);
    const Eigen::MatrixXd hessian = Eigen::MatrixXd::Constant(1, 1, jacobian.squaredNorm());
    const Eigen::VectorXd gradient = Eigen::VectorXd::Constant(1, jacobian.dot(r));
    const LmStep s = lm.step(hessian, gradient, best, th, [&](const Eigen::VectorXd& c) { return loss_of(residual(c[0])); });
    if (!s.accepted) break;
    const double gain = (best - s.loss) / best;
    best = s.loss;
    r = residual(th[0]);
    if (gain < 1e-9) break;
  }
  // a gain under 1e-9 of the harmonics' own power is rounding: the model matched them already
  if (best <= (1.0 - kRequiredGain) * out.error_before && out.error_before - best > 1e-9 * power) {
    out.used = true;
    out.scale = std::exp(bounded_log_scale(th[0]));
    out.model.friction_velocity *= out.scale;
    out.error_after = best;
  }
  return out;
}

EddyBranchSearch search_eddy_branch(const MirrorModel& model, int current_lag, const Eigen::VectorXd& drive,
                                    const Eigen::VectorXd& current, const CurrentSineRecord& record, double fs) {
  EddyBranchSearch out;
  const FrictionScaleRefit without = refit_friction_scale(model, current_lag, record, fs);
  out.model = without.model;
  out.error_without = without.error_after;
  out.error_with = out.error_without;
  MirrorCurrentFitOptions options;
  options.max_iterations = kEddyRefitIterations;
  // [M1]'s eddy branch: for each rate, r_b/e_R doubled from its smallest while the sines' harmonics improve
  for (double rate : kEddyRates) {
    double best_here = out.error_without;
    for (double ratio = kEddySmallestRatio; ratio <= 1.001 * kEddyLargestRatio; ratio *= 2.0) {
      EddyBranchTrial t;
      t.branch = {ratio * model.electrical[4], rate};
      t.harmonic_error = std::numeric_limits<double>::infinity();
      FrictionScaleRefit with;
      try {
        const MirrorCurrentFit refit =
            refit_mirror_model_from_current(drive, current, fs, add_eddy_branch(model, t.branch), current_lag, options);
        t.current_j_val_pct = refit.current_j_val_pct;
        with = refit_friction_scale(refit.model, current_lag, record, fs);
        t.harmonic_error = with.error_after;
      } catch (const std::invalid_argument&) {  // a branch the model runs away with: not a candidate
      }
      out.trials.push_back(t);
      if (t.harmonic_error < out.error_with) {
        out.error_with = t.harmonic_error;
        out.model = with.model;
        out.current_j_val_pct = t.current_j_val_pct;
      }
      if (!(t.harmonic_error < best_here)) break;
      best_here = t.harmonic_error;
    }
  }
  // used when it cuts the error by kEddyRequiredGain, makes no sine's worse (louder sines showed other mismatches
  // that a branch absorbed at one sine and not the other) and leaves the harmonics matched (kEddyLargestErrorShare)
  bool no_step_worse = true;
  const std::vector<std::vector<std::complex<double>>> target = record_harmonics(record, fs);
  double power = 0.0;
  for (const auto& step : target) {
    for (const std::complex<double>& h : step) power += std::norm(h);
  }
  if (out.error_with < out.error_without) {
    const Eigen::VectorXd before = harmonic_residual(without.model, current_lag, record, target, fs, 0.0);
    const Eigen::VectorXd after = harmonic_residual(out.model, current_lag, record, target, fs, 0.0);
    const Eigen::Index per = before.size() / static_cast<Eigen::Index>(record.steps.size());
    for (Eigen::Index k = 0; k * per < before.size() && after.size() == before.size(); ++k) {
      if (after.segment(k * per, per).squaredNorm() > before.segment(k * per, per).squaredNorm()) no_step_worse = false;
    }
  }
  out.used = no_step_worse && out.error_with <= (1.0 - kEddyRequiredGain) * out.error_without &&
             out.error_with <= kEddyLargestErrorShare * power;
  if (!out.used) {
    out.model = without.model;
    out.error_with = out.error_without;
    out.current_j_val_pct = -1.0;
  }
  return out;
}

}  // namespace panelbass::models

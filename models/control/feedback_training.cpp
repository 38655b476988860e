#include "models/control/feedback_training.h"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "dsp/soft_limit.h"
#include "models/optimization/levenberg_marquardt.h"

namespace panelbass::models {
namespace {

void require_data(const Eigen::VectorXd& u, const Eigen::VectorXd& y_desired, Eigen::Index skip, const char* which) {
  const std::string where = std::string("train_feedback: ") + which;
  if (u.size() != y_desired.size()) {
    throw std::invalid_argument(where + " u has " + std::to_string(u.size()) + " samples, y_desired " +
                                std::to_string(y_desired.size()));
  }
  if (u.size() <= skip) {
    throw std::invalid_argument(where + " data has " + std::to_string(u.size()) +
                                " samples, not more than the transient skip " + std::to_string(skip));
  }
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    if (!std::isfinite(u[k]) || !std::isfinite(y_desired[k])) {
      throw std::invalid_argument(where + " data is not finite at sample " + std::to_string(k));
    }
  }
}

// Tracking weights: none (all 1), or one finite w(k) >= 0 per sample.
void require_weights(const Eigen::VectorXd& weight, Eigen::Index samples, const char* which) {
  if (weight.size() == 0) return;
  const std::string where = std::string("train_feedback: ") + which;
  if (weight.size() != samples) {
    throw std::invalid_argument(where + " weights: " + std::to_string(weight.size()) + " for " +
                                std::to_string(samples) + " samples");
  }
  for (Eigen::Index k = 0; k < weight.size(); ++k) {
    if (!(std::isfinite(weight[k]) && weight[k] >= 0.0)) {
      throw std::invalid_argument(where + " weight at sample " + std::to_string(k) + " is not finite and >= 0");
    }
  }
}

/// Levenberg–Marquardt's settings here: μ from 1e-2 within [1e-10, 1e10], ÷10 on success, ×10 on failure,
/// 12 retries, the damping μ·(diag H + 1e-9·mean diag H).
constexpr LmSettings kLmSettings{.damping = LmDamping::relative_to_mean,
                                 .initial_lambda = 1e-2,
                                 .min_lambda = 1e-10,
                                 .max_lambda = 1e10,
                                 .retries = 12};

// A harmonic stretch as the sweeps use it: an orthonormal basis of its mean and harmonic series.
struct StretchBasis {
  Eigen::Index start = 0, length = 0;
  Eigen::MatrixXd q;  // length × (2K + 1): the mean, then sin and cos of each harmonic h·f < fs/2, h = 1..K

  // The least-squares fit of `x` (this stretch's samples) by the mean and the harmonics.
  Eigen::VectorXd fit(const Eigen::VectorXd& x) const { return q * (q.transpose() * x); }
};

// The bases of `stretches` on a record of `samples` at rate fs; std::invalid_argument (`who` first) naming the
// stretch if one does not fit the record, has no harmonic below fs/2 or is not longer than its components.
std::vector<StretchBasis> stretch_bases(const std::vector<HarmonicStretch>& stretches, Eigen::Index samples, double fs,
                                        const std::string& who) {
  std::vector<StretchBasis> bases;
  for (std::size_t i = 0; i < stretches.size(); ++i) {
    const HarmonicStretch& h = stretches[i];
    const std::string where = who + " harmonic stretch " + std::to_string(i) +
                              " (samples " + std::to_string(h.start) + " + " + std::to_string(h.length) + ")";
    if (h.start < 0 || h.length <= 0 || h.start + h.length > samples) {
      throw std::invalid_argument(where + " does not fit the record's " + std::to_string(samples) + " samples");
    }
    if (!(h.f > 0.0 && h.f < fs / 2.0)) {
      throw std::invalid_argument(where + ": f must be within (0, fs/2), got " + std::to_string(h.f) + " Hz");
    }
    if (h.harmonics < 1) throw std::invalid_argument(where + ": harmonics must be >= 1");
    int kept = 0;
    while (kept < h.harmonics && (kept + 1) * h.f < fs / 2.0) ++kept;
    const Eigen::Index components = 2 * kept + 1;
    if (h.length <= components) {
      throw std::invalid_argument(where + " is not longer than its " + std::to_string(components) + " components");
    }
    Eigen::MatrixXd basis(h.length, components);
    for (Eigen::Index k = 0; k < h.length; ++k) {
      const double phase = 2.0 * std::numbers::pi * h.f * static_cast<double>(k) / fs;
      basis(k, 0) = 1.0;
      for (int j = 1; j <= kept; ++j) {
        basis(k, 2 * j - 1) = std::sin(j * phase);
        basis(k, 2 * j) = std::cos(j * phase);
      }
    }
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(basis);
    bases.push_back({h.start, h.length, qr.householderQ() * Eigen::MatrixXd::Identity(h.length, components)});
  }
  return bases;
}

// One record as a sweep runs it: the feedforward output u (raw), the desired output (raw), the tracking weights
// (empty = 1), the device whose output is tracked (unset: the plant model's) and the harmonic stretches' bases.
struct SweepRecord {
  const Eigen::VectorXd& u;
  const Eigen::VectorXd& y_desired;
  const Eigen::VectorXd& weight;
  const DeviceOutput& measure;
  std::vector<StretchBasis> bases;
};

/// One pass of the loop over a record: the outputs, the loss, and (when asked) the Gauss–Newton normal
/// equations g = Σ r·∂r/∂θ, H = Σ ∂r/∂θ·∂r/∂θᵀ over the residuals r = e and √λ·p.
// Corner of the low-pass through which the drive-offset penalty sees N1's output, Hz: below the band-pass's
// lowest corner (20 Hz), so it weighs offsets and slow drifts, not the corrections in the band.
constexpr double kDcCornerHz = 5.0;

struct LoopSweep {
  const NeuralFeedback& c;
  Eigen::VectorXd v, v_scaled, y_scaled;
  Eigen::VectorXd tracked;  // the output the tracking error is taken of, scaled: ŷ_s, or the device's measured output
  Eigen::MatrixXd Dv, Dy;  // P×N: dv(k)/dθ and dŷ_s(k)/dθ
  Eigen::MatrixXd Dq;      // P×N: d/dθ of the drive-offset residuals √μ·low(k) (when μ > 0)
  Eigen::VectorXd dlow;    // d low(k)/dθ
  Mlp::Workspace ws;
  LoopPlantSweep plant;
  Eigen::VectorXd r, dr, dtheta, ds;

  LoopSweep(const NeuralFeedback& controller, Eigen::Index n)
      : c(controller), v(n), v_scaled(n), y_scaled(n), ws(controller.net.workspace()),
        plant(controller.plant, controller.net.parameter_count()), r(controller.structure.inputs()),
        dr(controller.structure.inputs()), dtheta(controller.net.parameter_count()),
        ds(controller.net.parameter_count()) {}

  /// Runs the loop on record `d`; returns V. With `g`/`H`, also the normal equations (normalised like V).
  /// `lambda`: λ of the rail penalty; `dc`: μ of the drive-offset penalty (FeedbackTrainingOptions::dc_penalty).
  double run(const SweepRecord& d, double lambda, double dc, Eigen::Index skip, Eigen::VectorXd* g, Eigen::MatrixXd* H) {
    const Eigen::VectorXd& u = d.u;
    const Eigen::VectorXd& weight = d.weight;
    const Eigen::Index n = u.size();
    const Eigen::Index P = c.net.parameter_count();
    const FeedbackStructure& s = c.structure;
    const Scaling& sc = c.plant.scaling();
    const bool jacobian = g != nullptr;
    if (jacobian) {
      Dv.setZero(P, n);
      Dy.setZero(P, n);
      if (dc > 0.0) Dq.setZero(P, n);
      dlow.setZero(P);
      g->setZero(P);
      H->setZero(P, P);
    }
    const double sqrt_lambda = std::sqrt(lambda);
    const double sqrt_dc = std::sqrt(dc);
    // the one-pole low-pass of N1's output whose every sample the drive-offset penalty weighs
    const double pole = std::exp(-2.0 * std::numbers::pi * kDcCornerHz / c.fs);
    double low = 0.0;
    double sum = 0.0;
    plant.start();
    for (Eigen::Index k = 0; k < n; ++k) {
      // the controller: s(k) = u(k) + N1(r(k)), v(k) = soft_limit(s(k))
      c.regressor(u, v, y_scaled, k, r);
      const double s_k = u[k] + c.net.forward(r, ws);
      v[k] = dsp::soft_limit(s_k, c.knee);
      v_scaled[k] = (v[k] - sc.u_offset) / sc.u_scale;
      if (jacobian) {
        c.net.backward(ws, dtheta, dr);
        // Appendix 3 [2]: dv/dθ1 = ∂N1/∂θ1 + ∂N1/∂v·W1(z⁻¹)·dv/dθ1 + ∂N1/∂y·W3(z⁻¹)·dy/dθ1 (times the limit's slope)
        ds = dtheta;
        for (Eigen::Index i = 1; i <= s.nv && k - i >= 0; ++i) ds.noalias() += dr[s.nu + i] * Dv.col(k - i);
        for (Eigen::Index i = 1; i <= s.ny && k - i >= 0; ++i) ds.noalias() += dr[s.nu + s.nv + i] * Dy.col(k - i);
        Dv.col(k) = dsp::soft_limit_slope(s_k, c.knee) * ds;
        if (dc > 0.0) dlow = pole * dlow + (1.0 - pole) * ds;  // ∂s/∂θ1 = ∂N1/∂θ1: u does not depend on θ1
      }
      low = pole * low + (1.0 - pole) * (s_k - u[k]);
      // the plant model: ŷ(k) from the drives (NARX: and its past outputs), and Appendix 3 [1]'s
      // dŷ/dθ1 through it (loop_plant.h: through the NARX network or the ss model's state recursion)
      y_scaled[k] = plant.step(k, v_scaled, y_scaled);
      if (jacobian) plant.sensitivities(k, Dv, Dy);
      if (k < skip) continue;
      const double over = std::abs(s_k) - c.knee;
      const double p = over > 0.0 ? sqrt_lambda * over : 0.0;
      const double q = sqrt_dc * low;
      sum += p * p + q * q;
      if (jacobian) {
        if (p > 0.0) {
          const double sign = s_k > 0.0 ? sqrt_lambda : -sqrt_lambda;
          g->noalias() += (p * sign) * ds;
          H->selfadjointView<Eigen::Lower>().rankUpdate(ds, sign * sign);
        }
        if (dc > 0.0) {
          g->noalias() += (q * sqrt_dc) * dlow;
          Dq.col(k) = sqrt_dc * dlow;
        }
      }
    }
    // the tracking residuals e(k) = y_s(k) − y_des(k)/y_scale, of the plant model's output or the device's (whose
    // sensitivities are taken as the model's: the drive does not depend on the device's output)
    if (d.measure) {
      const Eigen::VectorXd measured = d.measure(v);
      if (measured.size() != n || !measured.allFinite()) {
        throw std::invalid_argument("train_feedback: the device returned " + std::to_string(measured.size()) +
                                    " samples for " + std::to_string(n) + (measured.allFinite() ? "" : ", not all finite"));
      }
      tracked = measured / sc.y_scale;
    } else {
      tracked = y_scaled;
    }
    // on the harmonic stretches, the error's harmonic series alone, and the sensitivities' likewise (the
    // projection is linear, so the sensitivity of the projected error is the projected sensitivity)
    for (const StretchBasis& b : d.bases) {
      const Eigen::VectorXd target = d.y_desired.segment(b.start, b.length) / sc.y_scale;
      tracked.segment(b.start, b.length) = target + b.fit(tracked.segment(b.start, b.length) - target);
      if (jacobian) {
        const Eigen::MatrixXd projected = (Dy.middleCols(b.start, b.length) * b.q) * b.q.transpose();
        Dy.middleCols(b.start, b.length) = projected;
      }
    }
    Eigen::VectorXd we = (tracked - d.y_desired / sc.y_scale).tail(n - skip);
    sum += weight.size() > 0 ? (weight.tail(n - skip).array() * we.array().square()).sum() : we.squaredNorm();
    const double count = static_cast<double>(n - skip);
    if (jacobian) {
      if (weight.size() > 0) we.array() *= weight.tail(n - skip).array();
      g->noalias() += Dy.rightCols(n - skip) * we;
      // H += Σ w·ψψᵀ over the tracking residuals, as one product of the stored sensitivities (each scaled by
      // √w: they are not needed after this pass)
      if (weight.size() > 0) Dy.rightCols(n - skip) *= weight.tail(n - skip).cwiseSqrt().asDiagonal();
      const auto psi = Dy.rightCols(n - skip);
      H->selfadjointView<Eigen::Lower>().rankUpdate(psi);
      if (dc > 0.0) H->selfadjointView<Eigen::Lower>().rankUpdate(Dq.rightCols(n - skip));
      *H = H->selfadjointView<Eigen::Lower>();
      *g /= count;
      *H /= count;
    }
    return sum / (2.0 * count);
  }

  /// [2C] J_c of the last run on record `d` (weighted by its weights unless they are empty), percent.
  double jc(const SweepRecord& d, Eigen::Index skip) const {
    return jc_percent(tracked, d.y_desired / c.plant.scaling().y_scale, skip, d.weight);
  }

  /// Share of samples k ≥ skip whose unlimited output was above the knee in the last run.
  double rail_fraction(Eigen::Index skip) const {
    Eigen::Index count = 0;
    for (Eigen::Index k = skip; k < v.size(); ++k) count += std::abs(v[k]) > c.knee ? 1 : 0;
    return static_cast<double>(count) / static_cast<double>(v.size() - skip);
  }
};

}  // namespace

const FeedbackTrainingRecord* best_validation_record(const FeedbackTrainingResult& result) {
  const FeedbackTrainingRecord* best = nullptr;
  double best_jc = std::numeric_limits<double>::infinity();
  for (const FeedbackTrainingRecord& r : result.history) {
    if (r.jc_val_pct < best_jc) {
      best = &r;
      best_jc = r.jc_val_pct;
    }
  }
  return best;
}

double best_validation_jc_pct(const FeedbackTrainingResult& result) {
  const FeedbackTrainingRecord* best = best_validation_record(result);
  return best ? best->jc_val_pct : std::numeric_limits<double>::infinity();
}

Eigen::VectorXd harmonic_series(const Eigen::VectorXd& x, const std::vector<HarmonicStretch>& stretches, double fs) {
  Eigen::VectorXd fitted = x;
  for (const StretchBasis& b : stretch_bases(stretches, x.size(), fs, "harmonic_series:")) {
    fitted.segment(b.start, b.length) = b.fit(x.segment(b.start, b.length));
  }
  return fitted;
}

void initialize_feedback(NeuralFeedback& controller, std::uint64_t seed, double output_scale) {
  controller.net.initialize(1.0, seed);
  const int last = controller.structure.hidden.back();
  controller.net.parameters().tail(last + 1) *= output_scale;
}

double feedback_loss(const NeuralFeedback& controller, const Eigen::VectorXd& u, const Eigen::VectorXd& y_desired,
                     double rail_penalty, Eigen::Index skip, const Eigen::VectorXd& weight, double dc_penalty,
                     const std::vector<HarmonicStretch>& harmonic) {
  require_data(u, y_desired, skip, "");
  require_weights(weight, u.size(), "");
  const SweepRecord d{u, y_desired, weight, {}, stretch_bases(harmonic, u.size(), controller.fs, "train_feedback:")};
  LoopSweep sweep(controller, u.size());
  return sweep.run(d, rail_penalty, dc_penalty, skip, nullptr, nullptr);
}

Eigen::VectorXd feedback_gradient(const NeuralFeedback& controller, const Eigen::VectorXd& u,
                                  const Eigen::VectorXd& y_desired, double rail_penalty, Eigen::Index skip,
                                  const Eigen::VectorXd& weight, double dc_penalty,
                                  const std::vector<HarmonicStretch>& harmonic) {
  require_data(u, y_desired, skip, "");
  require_weights(weight, u.size(), "");
  const SweepRecord d{u, y_desired, weight, {}, stretch_bases(harmonic, u.size(), controller.fs, "train_feedback:")};
  LoopSweep sweep(controller, u.size());
  Eigen::VectorXd g;
  Eigen::MatrixXd H;
  sweep.run(d, rail_penalty, dc_penalty, skip, &g, &H);
  return g;
}

FeedbackTrainingResult train_feedback(const NeuralFeedback& initial, const Eigen::VectorXd& u_est,
                                      const Eigen::VectorXd& y_desired_est, const Eigen::VectorXd& u_val,
                                      const Eigen::VectorXd& y_desired_val, const FeedbackTrainingOptions& o) {
  const Eigen::Index skip = o.transient_skip;
  if (skip < 0) throw std::invalid_argument("train_feedback: transient_skip must be >= 0");
  if (!(o.rail_penalty >= 0.0) || !std::isfinite(o.rail_penalty)) {
    throw std::invalid_argument("train_feedback: rail_penalty must be finite and >= 0");
  }
  if (!(o.dc_penalty >= 0.0) || !std::isfinite(o.dc_penalty)) {
    throw std::invalid_argument("train_feedback: dc_penalty must be finite and >= 0");
  }
  require_data(u_est, y_desired_est, skip, "estimation");
  require_weights(o.weight_est, u_est.size(), "estimation");
  const bool has_validation = u_val.size() > 0;
  if (has_validation) require_data(u_val, y_desired_val, skip, "validation");
  if (has_validation) require_weights(o.weight_val, u_val.size(), "validation");
  if (!has_validation && !o.harmonic_val.empty()) {
    throw std::invalid_argument("train_feedback: harmonic stretches of the validation record, but no validation record");
  }
  const SweepRecord est_record{u_est, y_desired_est, o.weight_est, o.measure_est,
                               stretch_bases(o.harmonic_est, u_est.size(), initial.fs, "train_feedback: estimation")};
  const SweepRecord val_record{u_val, y_desired_val, o.weight_val, o.measure_val,
                               stretch_bases(o.harmonic_val, u_val.size(), initial.fs, "train_feedback: validation")};

  FeedbackTrainingResult result{initial, {}, 0};
  NeuralFeedback current = initial;
  NeuralFeedback trial = initial;
  LoopSweep est(current, u_est.size()), trial_sweep(trial, u_est.size());
  LoopSweep val(current, has_validation ? u_val.size() : 0);
  const auto record = [&](int iteration) {
    FeedbackTrainingRecord r;
    r.iteration = iteration;
    est.run(est_record, o.rail_penalty, o.dc_penalty, skip, nullptr, nullptr);
    r.jc_est_pct = est.jc(est_record, skip);
    r.rail_fraction = est.rail_fraction(skip);
    r.jc_val_pct = std::numeric_limits<double>::quiet_NaN();
    if (has_validation) {
      val.run(val_record, o.rail_penalty, o.dc_penalty, skip, nullptr, nullptr);
      r.jc_val_pct = val.jc(val_record, skip);
    }
    result.history.push_back(r);
    if (o.progress) o.progress(r);
    return r;
  };
  const auto score = [&](const FeedbackTrainingRecord& r) { return has_validation ? r.jc_val_pct : r.jc_est_pct; };
  double best = score(record(0));
  int since_best = 0;
  LevenbergMarquardt lm(kLmSettings, current.net.parameter_count());
  Eigen::VectorXd g;
  Eigen::MatrixXd H;
  for (int it = 1; it <= o.max_iterations; ++it) {
    const double V = est.run(est_record, o.rail_penalty, o.dc_penalty, skip, &g, &H);
    // Levenberg–Marquardt on (H, g) through the loop; a non-finite V, g or H ends training.
    const bool improved = lm.step(H, g, V, current.net.parameters(), [&](const Eigen::VectorXd& candidate) {
                            trial.net.parameters() = candidate;
                            return trial_sweep.run(est_record, o.rail_penalty, o.dc_penalty, skip, nullptr, nullptr);
                          }).accepted;
    if (!improved) break;
    result.iterations = it;
    const double s = score(record(it));
    if (s < best || !o.early_stopping) {
      best = std::min(best, s);
      since_best = 0;
      result.controller.net.parameters() = current.net.parameters();
    } else if (++since_best >= o.patience) {
      break;
    }
  }
  if (!o.early_stopping) result.controller.net.parameters() = current.net.parameters();
  return result;
}

}  // namespace panelbass::models

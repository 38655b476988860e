#include "models/diagnosis/diagnosis_stopping.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <unsupported/Eigen/FFT>
#include <stdexcept>
#include <utility>
#include <vector>

#include "dsp/period.h"
#include "models/diagnosis/diagnosis_candidates.h"
#include "models/validation/performance.h"

namespace panelbass::models::diagnosis_detail {
namespace {

// The validation test's batches: at least kMinBatch samples each (a few periods of a low resonance, longer than the
// correlation of a whitened residual), between kMinBatches and kMaxBatches of them.
constexpr Eigen::Index kMinBatch = 100;
constexpr Eigen::Index kMinBatches = 20;
constexpr Eigen::Index kMaxBatches = 100;
// A record too short for kMinBatches batches of kMinBatch samples gets shorter ones, down to this.
constexpr Eigen::Index kShortestBatch = 10;

// Half the width, in DFT bins, of the running mean that smooths the noise's periodogram into its spectrum.
constexpr Eigen::Index kSmoothingBins = 16;

// `before` and `after` whitened by the spectrum of `after` (its periodogram smoothed over 2·kSmoothingBins + 1
// bins): each DFT bin divided by the noise's amplitude there, and back to time. A noise model of any colour
// (a 1/f noise down to a few hertz included, which a short AR model cannot follow).
std::pair<Eigen::VectorXd, Eigen::VectorXd> whitened(const Eigen::VectorXd& before, const Eigen::VectorXd& after) {
  const Eigen::Index n = before.size();
  Eigen::FFT<double> fft;
  std::vector<double> xb(before.data(), before.data() + n), xa(after.data(), after.data() + n);
  std::vector<std::complex<double>> fb, fa;
  fft.fwd(fb, xb);
  fft.fwd(fa, xa);
  const Eigen::Index half = n / 2;
  Eigen::VectorXd power(half + 1);
  for (Eigen::Index k = 0; k <= half; ++k) power[k] = std::norm(fa[static_cast<std::size_t>(k)]);
  Eigen::VectorXd spectrum(half + 1);
  for (Eigen::Index k = 0; k <= half; ++k) {
    const Eigen::Index lo = std::max<Eigen::Index>(0, k - kSmoothingBins), hi = std::min(half, k + kSmoothingBins);
    spectrum[k] = power.segment(lo, hi - lo + 1).mean();
  }
  const double tiny = 1e-300 + 1e-12 * spectrum.maxCoeff();
  for (Eigen::Index k = 0; k < n; ++k) {
    const double weight = 1.0 / std::sqrt(std::max(spectrum[std::min(k, n - k)], tiny));
    fb[static_cast<std::size_t>(k)] *= weight;
    fa[static_cast<std::size_t>(k)] *= weight;
  }
  fft.inv(xb, fb);
  fft.inv(xa, fa);
  return {Eigen::Map<const Eigen::VectorXd>(xb.data(), n), Eigen::Map<const Eigen::VectorXd>(xa.data(), n)};
}

}  // namespace

std::string to_string(FloorSource source) {
  switch (source) {
    case FloorSource::repeated_periods: return "repeated periods";
    case FloorSource::top_band: return "the residual's top band";
    case FloorSource::no_candidate: return "what no candidate explains";
  }
  return "the residual's top band";
}

std::optional<NoiseFloor> periodic_noise_floor(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) {
  if (u.size() != y.size() || init < 0 || u.size() - init < 64) return std::nullopt;
  const Eigen::Index n = u.size() - init;
  const Eigen::VectorXd u_judged = u.tail(n), y_judged = y.tail(n);
  dsp::PeriodSearch search;
  search.min_repeats = 3;
  const Eigen::Index period = dsp::find_period(u_judged, search);
  if (period == 0) return std::nullopt;
  // The whole periods at the end, the first of them left to settle: at least three judged.
  const Eigen::Index whole = n / period - 1;
  if (whole < 3) return std::nullopt;
  const Eigen::Index used = whole * period;
  const Eigen::VectorXd y_used = y_judged.tail(used);
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(period);
  for (Eigen::Index p = 0; p < whole; ++p) mean += y_used.segment(p * period, period);
  mean /= static_cast<double>(whole);
  double spread = 0.0;
  for (Eigen::Index p = 0; p < whole; ++p) spread += (y_used.segment(p * period, period) - mean).squaredNorm();
  // σ² = Σ_p Σ_k (y_p(k) − ȳ(k))² / ((P − 1)·L): unbiased whatever repeats (the response and its distortion).
  const double variance = spread / static_cast<double>((whole - 1) * period);
  const double energy = y_judged.squaredNorm();
  if (!(energy > 0.0)) return std::nullopt;
  NoiseFloor f;
  f.pct = j_ratio_percent(variance * static_cast<double>(n), energy);  // [2A] of a model that left only the noise
  // A variance from (P − 1)·L degrees of freedom (white noise) is good to √(2/dof).
  f.relative_sd = std::sqrt(2.0 / static_cast<double>((whole - 1) * period));
  f.source = FloorSource::repeated_periods;
  return f;
}

double normal_upper_quantile(double p) {
  if (!(p > 0.0 && p < 1.0)) throw std::invalid_argument("normal_upper_quantile: p = " + std::to_string(p) + " is not in (0, 1)");
  // Bisection on P(Z > z) = erfc(z/√2)/2, decreasing in z.
  double low = -40.0, high = 40.0;
  for (int k = 0; k < 200; ++k) {
    const double mid = 0.5 * (low + high);
    if (0.5 * std::erfc(mid / std::sqrt(2.0)) > p) low = mid; else high = mid;
  }
  return 0.5 * (low + high);
}

double student_upper_quantile(double p, double dof) {
  const double z = normal_upper_quantile(p);
  // Cornish–Fisher expansion of t_ν in 1/ν (Abramowitz and Stegun 26.7.5, two terms).
  const double z3 = z * z * z, z5 = z3 * z * z;
  return z + (z3 + z) / (4.0 * dof) + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * dof * dof);
}

ValidationGain validation_gain(const Eigen::VectorXd& before, const Eigen::VectorXd& after, int tried) {
  if (before.size() != after.size() || before.size() < kMinBatches * kShortestBatch)
    throw std::invalid_argument("validation_gain: residuals of " + std::to_string(before.size()) + " and " +
                                std::to_string(after.size()) + " samples; at least " +
                                std::to_string(kMinBatches * kShortestBatch) + " needed");
  ValidationGain g;
  g.tried = std::max(1, tried);
  g.gain = before.squaredNorm() > 0.0 ? (before.squaredNorm() - after.squaredNorm()) / before.squaredNorm() : 0.0;
  // The test runs on the residuals whitened by a noise model (generalised least squares): a coloured residual then
  // counts its gains where the noise is low, not where it is high. The model is that of `after`, the residual
  // with less of the effect in it: one of `before` would whiten the effect away.
  const auto [wb, wa] = whitened(before, after);
  const Eigen::Index n = wb.size();
  const Eigen::ArrayXd d = wb.array().square() - wa.array().square();
  // Batch means of d, ranked by size: Wilcoxon's signed-rank statistic. A nonlinear term's gain is heavy-tailed
  // (made where the motion peaks), so a t of the batch means would be swamped by the few batches that hold a peak;
  // the ranks count how consistently the gain is made. Noise alone gives batch means symmetric about a small
  // negative mean (what a fit to other noise costs), so the test errs on the side of no finding.
  const int batches = static_cast<int>(std::clamp<Eigen::Index>(n / kMinBatch, kMinBatches, kMaxBatches));
  const Eigen::Index batch = n / batches;
  std::vector<double> means;
  for (int b = 0; b < batches; ++b) {
    const double m = d.segment(b * batch, batch).mean();
    if (m != 0.0) means.push_back(m);
  }
  std::vector<std::size_t> order(means.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return std::abs(means[a]) < std::abs(means[b]); });
  double positive_ranks = 0.0;
  for (std::size_t rank = 0; rank < order.size(); ++rank)
    if (means[order[rank]] > 0.0) positive_ranks += static_cast<double>(rank + 1);
  const double m = static_cast<double>(means.size());
  const double spread = std::sqrt(m * (m + 1.0) * (2.0 * m + 1.0) / 24.0);
  g.batches = batches;
  g.z = spread > 0.0 ? (positive_ranks - m * (m + 1.0) / 4.0) / spread : 0.0;
  g.threshold = normal_upper_quantile(kFamilyLevel / g.tried);
  g.significant = g.z > g.threshold;
  return g;
}

nlohmann::json validation_gain_to_json(const ValidationGain& g) {
  return {{"gain_share_of_J", g.gain}, {"z", g.z}, {"threshold", g.threshold}, {"candidates_tried", g.tried},
          {"batches", g.batches}, {"family_level", kFamilyLevel}, {"significant", g.significant}};
}

NoiseFloor diagnosis_noise_floor(const Records& r, const Fit& baseline, const ResidualLocation& located_val,
                                 double& no_candidate_pct) {
  no_candidate_pct = std::numeric_limits<double>::quiet_NaN();
  if (const auto periodic = periodic_noise_floor(r.u_val, r.y_val, r.init)) return *periodic;
  NoiseFloor floor{located_val.noise_floor_pct, located_val.noise_floor_relative_sd, FloorSource::top_band};
  no_candidate_pct = every_term_at_once(r, baseline).j_val;
  // A validation J is good to √(2/N_eff) of itself.
  if (no_candidate_pct < floor.pct)
    floor = {no_candidate_pct, std::sqrt(2.0 / std::max(located_val.effective_samples, 2.0)), FloorSource::no_candidate};
  return floor;
}

nlohmann::json noise_floor_to_json(const NoiseFloor& floor, double top_band_pct, double no_candidate_pct) {
  return {{"pct", floor.pct},
          {"relative_sd", floor.relative_sd},
          {"source", to_string(floor.source)},
          {"top_band_pct", top_band_pct},
          {"no_candidate_pct", std::isfinite(no_candidate_pct) ? nlohmann::json(no_candidate_pct) : nlohmann::json(nullptr)}};
}

}  // namespace panelbass::models::diagnosis_detail

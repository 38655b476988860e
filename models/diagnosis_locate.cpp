#include "models/diagnosis_locate.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "dsp/spectrum.h"

namespace panelbass::models {
namespace {

double rms(const Eigen::VectorXd& x) { return x.size() == 0 ? 0.0 : std::sqrt(x.squaredNorm() / static_cast<double>(x.size())); }

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Least-squares gain of y on ŷ.
double ls_gain(const Eigen::VectorXd& y, const Eigen::VectorXd& y_sim) {
  const double d = y_sim.squaredNorm();
  return d > 0.0 ? y_sim.dot(y) / d : 0.0;
}

}  // namespace

ResidualLocation locate_residual(const Eigen::VectorXd& u_all, const Eigen::VectorXd& y_all,
                                 const Eigen::VectorXd& y_sim_all, double fs, Eigen::Index start) {
  if (u_all.size() != y_all.size() || y_sim_all.size() != y_all.size())
    throw std::invalid_argument("locate_residual: u, y and the simulation differ in length (" +
                                std::to_string(u_all.size()) + ", " + std::to_string(y_all.size()) + ", " +
                                std::to_string(y_sim_all.size()) + ")");
  const Eigen::Index n = y_all.size() - start;
  if (start < 0 || n < 256)
    throw std::invalid_argument("locate_residual: " + std::to_string(std::max<Eigen::Index>(n, 0)) +
                                " samples after the first " + std::to_string(start) + "; at least 256 needed");
  const Eigen::VectorXd u = u_all.tail(n), y = y_all.tail(n), y_sim = y_sim_all.tail(n);
  const Eigen::VectorXd e = y - y_sim;
  ResidualLocation r;
  const double y_energy = y.squaredNorm();
  r.residual_pct = y_energy > 0.0 ? 100.0 * e.squaredNorm() / y_energy : 0.0;

  // Frequency: Welch PSD; the noise level is the median over the top quarter of the band, where a
  // band-limited plant puts least energy and sensor noise is white.
  std::size_t segment = 256;
  while (segment * 16 <= static_cast<std::size_t>(n) && segment < 2048) segment *= 2;
  const dsp::PowerSpectrum psd = dsp::welch_psd(e, fs, {segment, 0.5, dsp::Window::hann});
  const Eigen::Index bins = psd.psd.size();
  std::vector<double> top;
  for (Eigen::Index k = (3 * bins) / 4; k < bins - 1; ++k) top.push_back(psd.psd[k]);
  // The median of a χ²₂ₖ-distributed average lies slightly below its mean; for K ≥ 8 segments that bias
  // is under 5 %, so the median is used as it is.
  r.noise_psd = median(top);
  const double noise_variance = r.noise_psd * fs / 2.0;
  r.noise_floor_pct = y_energy > 0.0 ? 100.0 * noise_variance * static_cast<double>(n) / y_energy : 0.0;
  Eigen::Index peak = 2;
  for (Eigen::Index k = 2; k < bins - 1; ++k)
    if (psd.psd[k] > psd.psd[peak]) peak = k;
  r.peak_frequency_hz = psd.frequency[peak];
  r.peak_over_noise = r.noise_psd > 0.0 ? psd.psd[peak] / r.noise_psd : 0.0;
  // K averaged segments (50 % overlap, Hann: ≈ 0.95·K independent ones): a bin of pure noise is
  // ≈ normal with relative standard deviation 1/√K; 3.1 of those is the 0.1 % tail.
  const double segments = std::max(1.0, 2.0 * static_cast<double>(n) / static_cast<double>(segment) - 1.0);
  r.peak_threshold = 1.0 + 3.1 / std::sqrt(0.95 * segments);

  // Mean and its standard error from 20 block means (the residual is coloured, so not σ/√N).
  r.mean = e.mean();
  constexpr int kBlocks = 20;
  const Eigen::Index block = n / kBlocks;
  Eigen::VectorXd means(kBlocks);
  for (int b = 0; b < kBlocks; ++b) means[b] = e.segment(b * block, block).mean();
  const double sd = std::sqrt((means.array() - means.mean()).square().sum() / (kBlocks - 1));
  r.mean_t = sd > 0.0 ? means.mean() / (sd / std::sqrt(static_cast<double>(kBlocks))) : 0.0;

  // Amplitude: residual rms where |u| is in its top quartile against its bottom quartile.
  std::vector<double> magnitude(static_cast<std::size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k) magnitude[static_cast<std::size_t>(k)] = std::abs(u[k]);
  std::vector<double> sorted = magnitude;
  std::sort(sorted.begin(), sorted.end());
  const double q1 = sorted[sorted.size() / 4], q3 = sorted[(3 * sorted.size()) / 4];
  double low = 0.0, high = 0.0;
  Eigen::Index n_low = 0, n_high = 0;
  for (Eigen::Index k = 0; k < n; ++k) {
    if (magnitude[static_cast<std::size_t>(k)] <= q1) low += e[k] * e[k], ++n_low;
    if (magnitude[static_cast<std::size_t>(k)] >= q3) high += e[k] * e[k], ++n_high;
  }
  if (n_low > 0 && n_high > 0 && low > 0.0) r.level_ratio = std::sqrt((high / n_high) / (low / n_low));

  // Time: the first and last quarters.
  const Eigen::Index quarter = n / 4;
  const double first = rms(e.head(quarter));
  if (first > 0.0) r.drift_ratio = rms(e.tail(quarter)) / first;
  r.gain_drift = ls_gain(y.tail(quarter), y_sim.tail(quarter)) - ls_gain(y.head(quarter), y_sim.head(quarter));

  // Input–residual cross-correlation over ±10 samples (a delay error shows as a peak at a lag).
  const Eigen::VectorXd uc = u.array() - u.mean(), ec = e.array() - e.mean();
  const double norm = uc.norm() * ec.norm();
  for (int lag = -10; lag <= 10 && norm > 0.0; ++lag) {
    double s = 0.0;
    for (Eigen::Index k = std::max<Eigen::Index>(0, lag); k < n && k - lag < n; ++k) s += ec[k] * uc[k - lag];
    if (std::abs(s / norm) > std::abs(r.xcorr_peak)) r.xcorr_peak = s / norm, r.xcorr_lag = lag;
  }
  return r;
}

nlohmann::json location_to_json(const ResidualLocation& l) {
  return {{"noise_psd", l.noise_psd},
          {"noise_floor_pct", l.noise_floor_pct},
          {"residual_pct", l.residual_pct},
          {"peak_frequency_hz", l.peak_frequency_hz},
          {"peak_over_noise", l.peak_over_noise},
          {"peak_threshold", l.peak_threshold},
          {"mean", l.mean},
          {"mean_t", l.mean_t},
          {"level_ratio", l.level_ratio},
          {"drift_ratio", l.drift_ratio},
          {"gain_drift", l.gain_drift},
          {"xcorr_lag", l.xcorr_lag},
          {"xcorr_peak", l.xcorr_peak}};
}

}  // namespace panelbass::models

#include "models/diagnosis/diagnosis_locate.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/FFT>
#include <vector>

#include "dsp/best_linear_approximation.h"
#include "dsp/correlation.h"
#include "dsp/period.h"
#include "dsp/spectrum.h"
#include "models/diagnosis/diagnosis_terms.h"
#include "models/io/json_fields.h"
#include "models/validation/performance.h"

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

// Residual rms where `level` is in its top quartile over that where it is in its bottom quartile.
double quartile_rms_ratio(const Eigen::VectorXd& e, const Eigen::VectorXd& level) {
  std::vector<double> sorted(level.data(), level.data() + level.size());
  std::sort(sorted.begin(), sorted.end());
  const double q1 = sorted[sorted.size() / 4], q3 = sorted[(3 * sorted.size()) / 4];
  double low = 0.0, high = 0.0;
  Eigen::Index n_low = 0, n_high = 0;
  for (Eigen::Index k = 0; k < e.size(); ++k) {
    if (level[k] <= q1) low += e[k] * e[k], ++n_low;
    if (level[k] >= q3) high += e[k] * e[k], ++n_high;
  }
  return n_low > 0 && n_high > 0 && low > 0.0 ? std::sqrt((high / n_high) / (low / n_low)) : 1.0;
}

// N/τ with τ = 1 + 2·Σρ(k) summed while the residual's autocorrelation ρ stays positive (at most 200 lags):
// how many independent samples a coloured residual is worth for a mean.
double effective_samples(const Eigen::VectorXd& e) {
  const Eigen::Index n = e.size();
  const Eigen::VectorXd ec = e.array() - e.mean();
  if (!(ec.squaredNorm() > 0.0)) return static_cast<double>(n);
  const Eigen::VectorXd rho = dsp::autocorrelation(ec, std::min<Eigen::Index>(200, n / 4));
  double tau = 1.0;
  for (Eigen::Index k = 1; k < rho.size() && rho[k] > 0.0; ++k) tau += 2.0 * rho[k];
  return static_cast<double>(n) / tau;
}

// Where the input explains the residual: the coherence of u and e over the band the input excites.
FrfError frf_error(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const Eigen::VectorXd& e, double fs,
                   std::size_t segment) {
  FrfError f;
  const dsp::WelchSpec spec{segment, 0.5, dsp::Window::hann};
  const dsp::FrequencyResponse residual = dsp::h1_frf(u, e, fs, spec);
  const dsp::FrequencyResponse response = dsp::h1_frf(u, y, fs, spec);
  const dsp::PowerSpectrum input = dsp::welch_psd(u, fs, spec);
  const Eigen::Index bins = input.psd.size();
  const double strongest = input.psd.segment(1, bins - 2).maxCoeff();
  std::vector<bool> excited(static_cast<std::size_t>(bins), false);
  int excited_bins = 0;
  for (Eigen::Index k = 1; k < bins - 1; ++k)
    if (input.psd[k] > 1e-3 * strongest) excited[static_cast<std::size_t>(k)] = true, ++excited_bins;
  if (excited_bins == 0) return f;
  // Under "u explains none of e", a coherence from K independent averages exceeds x with probability
  // (1 − x)^(K−1); K is taken as the non-overlapping segments (50 % overlap adds less than it counts), and
  // the 1 % is shared over the excited bins.
  const double averages = std::max(2.0, std::floor(static_cast<double>(u.size()) / static_cast<double>(segment)));
  f.threshold = 1.0 - std::pow(0.01 / excited_bins, 1.0 / (averages - 1.0));
  Eigen::Index peak = -1;
  for (Eigen::Index k = 1; k < bins - 1; ++k)
    if (excited[static_cast<std::size_t>(k)] && (peak < 0 || residual.coherence[k] > residual.coherence[peak])) peak = k;
  f.frequency_hz = residual.frequency[peak];
  f.coherence = residual.coherence[peak];
  const double ratio = std::abs(residual.h[peak]) / std::max(std::abs(response.h[peak]), 1e-300);
  f.relative_db = ratio > 0.0 ? 20.0 * std::log10(ratio) : -std::numeric_limits<double>::infinity();
  f.significant = f.coherence > f.threshold;
  Eigen::Index low = peak, high = peak;
  if (f.significant) {
    while (low > 1 && excited[static_cast<std::size_t>(low - 1)] && residual.coherence[low - 1] > f.threshold) --low;
    while (high < bins - 2 && excited[static_cast<std::size_t>(high + 1)] && residual.coherence[high + 1] > f.threshold) ++high;
  }
  f.band_low_hz = residual.frequency[low];
  f.band_high_hz = residual.frequency[high];
  return f;
}

// Distortion at the empty lines of a periodic record: the BLA's detection lines of y and of e, one
// realisation, noise from the variation between periods.
PeriodicDistortion periodic_distortion(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const Eigen::VectorXd& e,
                                       double fs) {
  PeriodicDistortion d;
  dsp::PeriodSearch search;
  search.min_repeats = 3;
  const Eigen::Index period = dsp::find_period(u, search);
  if (period == 0) return d;
  d.periodic = true;
  d.period = period;
  const Eigen::Index whole = u.size() / period;
  d.periods = static_cast<int>(whole - 1);
  const Eigen::Index used = whole * period;
  // The excited lines: those carrying the input, over the last period.
  Eigen::FFT<double> fft;
  std::vector<double> last(u.data() + u.size() - period, u.data() + u.size());
  std::vector<std::complex<double>> spectrum;
  fft.fwd(spectrum, last);
  double strongest = 0.0;
  for (Eigen::Index k = 1; 2 * k < period; ++k) strongest = std::max(strongest, std::norm(spectrum[static_cast<std::size_t>(k)]));
  dsp::BlaSpec spec;
  spec.period = static_cast<std::size_t>(period);
  spec.transient_periods = 1;
  spec.fs = fs;
  for (Eigen::Index k = 1; 2 * k < period; ++k)
    if (std::norm(spectrum[static_cast<std::size_t>(k)]) > 1e-6 * strongest) spec.excited_lines.push_back(static_cast<std::size_t>(k));
  d.excited_lines = static_cast<int>(spec.excited_lines.size());
  d.threshold_db = spec.detection_threshold_db;
  if (spec.excited_lines.empty()) return d;
  d.odd_lines_only = std::all_of(spec.excited_lines.begin(), spec.excited_lines.end(), [](std::size_t k) { return k % 2 == 1; });
  if (!d.odd_lines_only) return d;
  const std::vector<Eigen::VectorXd> inputs{u.tail(used)};
  const dsp::BestLinearApproximation output = dsp::best_linear_approximation(inputs, {y.tail(used)}, spec);
  const dsp::BestLinearApproximation residual = dsp::best_linear_approximation(inputs, {e.tail(used)}, spec);
  d.output_even_db = output.even.level_to_noise_db;
  d.output_odd_db = output.odd.level_to_noise_db;
  d.residual_even_db = residual.even.level_to_noise_db;
  d.residual_odd_db = residual.odd.level_to_noise_db;
  return d;
}

// The residual against a state: bin means (equal-count bins), quartile ratio, direction of change.
StateProfile state_profile(const std::string& name, const Eigen::VectorXd& state, const Eigen::VectorXd& e,
                           double effective) {
  constexpr int kBins = 12;
  StateProfile p;
  p.state = name;
  const Eigen::Index n = e.size();
  const double inflation = static_cast<double>(n) / std::max(1.0, effective);  // variance of a mean: × N/N_eff
  const Eigen::VectorXd ec = e.array() - e.mean();
  const double sd = std::sqrt(ec.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, n - 1)));
  const Eigen::VectorXd centred = state.array() - state.mean();
  const double scale = std::sqrt(centred.squaredNorm() / static_cast<double>(n));
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k) order[static_cast<std::size_t>(k)] = k;
  std::sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) { return centred[a] < centred[b]; });
  p.centre.resize(kBins);
  p.mean.resize(kBins);
  double chi2 = 0.0;
  for (int b = 0; b < kBins; ++b) {
    const std::size_t from = static_cast<std::size_t>(n) * b / kBins, to = static_cast<std::size_t>(n) * (b + 1) / kBins;
    double s = 0.0, c = 0.0;
    for (std::size_t i = from; i < to; ++i) s += ec[order[i]], c += centred[order[i]];
    const double count = static_cast<double>(to - from);
    p.centre[b] = scale > 0.0 ? c / count / scale : 0.0;
    p.mean[b] = s / count + e.mean();
    const double standard_error = sd * std::sqrt(inflation / count);
    if (standard_error > 0.0) chi2 += (s / count) * (s / count) / (standard_error * standard_error);
  }
  p.shape_chi2 = chi2 / (kBins - 1);
  p.shape_significant = state_dependence_significant(p.shape_chi2);
  p.level_ratio = quartile_rms_ratio(e, centred.cwiseAbs());
  double rising = 0.0, falling = 0.0;
  Eigen::Index n_rising = 0, n_falling = 0;
  for (Eigen::Index k = 1; k < n; ++k) {
    if (state[k] > state[k - 1]) rising += ec[k], ++n_rising;
    if (state[k] < state[k - 1]) falling += ec[k], ++n_falling;
  }
  if (n_rising > 0 && n_falling > 0 && sd > 0.0) {
    const double difference = rising / static_cast<double>(n_rising) - falling / static_cast<double>(n_falling);
    p.direction_t = difference / (sd * std::sqrt(inflation * (1.0 / static_cast<double>(n_rising) + 1.0 / static_cast<double>(n_falling))));
  }
  p.direction_significant = t_significant(p.direction_t);
  return p;
}

}  // namespace

bool state_dependence_significant(double shape_chi2) { return shape_chi2 > kShapeChi2Significant; }

bool t_significant(double t) { return std::abs(t) > kTSignificant; }

bool peak_significant(double peak_over_noise, double peak_threshold) { return peak_over_noise > peak_threshold; }

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
  r.residual_pct = y_energy > 0.0 ? j_ratio_percent(e.squaredNorm(), y_energy) : 0.0;

  // Frequency: Welch PSD; the noise level is the median over the top quarter of the band, where a
  // band-limited plant puts least energy and sensor noise is white.
  const std::size_t segment = dsp::residual_welch_segment(n);
  const dsp::PowerSpectrum psd = dsp::welch_psd(e, fs, {segment, 0.5, dsp::Window::hann});
  const Eigen::Index bins = psd.psd.size();
  std::vector<double> top;
  for (Eigen::Index k = (3 * bins) / 4; k < bins - 1; ++k) top.push_back(psd.psd[k]);
  // The median of a χ²₂ₖ-distributed average lies slightly below its mean; for K ≥ 8 segments that bias
  // is under 5 %, so the median is used as it is.
  r.noise_psd = median(top);
  const double noise_variance = r.noise_psd * fs / 2.0;
  r.noise_floor_pct = y_energy > 0.0 ? j_ratio_percent(noise_variance * static_cast<double>(n), y_energy) : 0.0;
  Eigen::Index peak = 2;
  for (Eigen::Index k = 2; k < bins - 1; ++k)
    if (psd.psd[k] > psd.psd[peak]) peak = k;
  r.peak_frequency_hz = psd.frequency[peak];
  r.peak_over_noise = r.noise_psd > 0.0 ? psd.psd[peak] / r.noise_psd : 0.0;
  // K averaged segments (50 % overlap, Hann: ≈ 0.95·K independent ones): a bin of pure noise is
  // ≈ normal with relative standard deviation 1/√K; 3.1 of those is the 0.1 % tail.
  const double segments = std::max(1.0, 2.0 * static_cast<double>(n) / static_cast<double>(segment) - 1.0);
  // The floor's uncertainty: each bin an average of ≈ 0.95·K independent segments (relative sd 1/√(0.95·K)),
  // neighbouring Hann bins half independent, and a median √(π/2) times as spread as a mean.
  r.noise_floor_relative_sd =
      std::sqrt(std::numbers::pi / 2.0) / std::sqrt(0.95 * segments * std::max(1.0, static_cast<double>(top.size()) / 2.0));
  r.peak_threshold = 1.0 + 3.1 / std::sqrt(0.95 * segments);
  r.peak_significant = peak_significant(r.peak_over_noise, r.peak_threshold);

  // Mean and its standard error from 20 block means (the residual is coloured, so not σ/√N).
  r.mean = e.mean();
  constexpr int kBlocks = 20;
  const Eigen::Index block = n / kBlocks;
  Eigen::VectorXd means(kBlocks);
  for (int b = 0; b < kBlocks; ++b) means[b] = e.segment(b * block, block).mean();
  const double sd = std::sqrt((means.array() - means.mean()).square().sum() / (kBlocks - 1));
  r.mean_t = sd > 0.0 ? means.mean() / (sd / std::sqrt(static_cast<double>(kBlocks))) : 0.0;

  // Amplitude: residual rms where |u| (|ŷ|) is in its top quartile against its bottom quartile.
  r.level_ratio = quartile_rms_ratio(e, u.cwiseAbs());
  r.output_level_ratio = quartile_rms_ratio(e, (y_sim.array() - y_sim.mean()).abs().matrix());

  // Time: the first and last quarters.
  const Eigen::Index quarter = n / 4;
  const double first = rms(e.head(quarter));
  if (first > 0.0) r.drift_ratio = rms(e.tail(quarter)) / first;
  r.gain_drift = ls_gain(y.tail(quarter), y_sim.tail(quarter)) - ls_gain(y.head(quarter), y_sim.head(quarter));

  // Onset: the split of the 20 blocks (at least two on each side) where the residual's power changes most
  // (largest likelihood ratio of two levels against one), judged by Welch's t on the blocks' log power.
  Eigen::VectorXd power(kBlocks);
  for (int b = 0; b < kBlocks; ++b) power[b] = std::max(e.segment(b * block, block).squaredNorm() / static_cast<double>(block), 1e-300);
  double best_ratio = -1.0;
  int split = kBlocks / 2;
  for (int j = 2; j <= kBlocks - 2; ++j) {
    const double before = power.head(j).mean(), after = power.tail(kBlocks - j).mean();
    const double ratio = kBlocks * std::log(power.mean()) - j * std::log(before) - (kBlocks - j) * std::log(after);
    if (ratio > best_ratio) best_ratio = ratio, split = j;
  }
  r.change_time_s = static_cast<double>(start + split * block) / fs;
  r.change_ratio = std::sqrt(power.tail(kBlocks - split).mean() / power.head(split).mean());
  const Eigen::ArrayXd log_before = power.head(split).array().log(), log_after = power.tail(kBlocks - split).array().log();
  const auto variance_of = [](const Eigen::ArrayXd& x) { return (x - x.mean()).square().sum() / static_cast<double>(x.size() - 1); };
  const double spread = std::sqrt(variance_of(log_before) / static_cast<double>(split) +
                                  variance_of(log_after) / static_cast<double>(kBlocks - split));
  r.change_t = spread > 0.0 ? (log_after.mean() - log_before.mean()) / spread : 0.0;
  r.change_significant = t_significant(r.change_t);

  // Input–residual cross-correlation over ±10 samples (a delay error shows as a peak at a lag).
  const Eigen::VectorXd uc = u.array() - u.mean(), ec = e.array() - e.mean();
  const double norm = uc.norm() * ec.norm();
  for (int lag = -10; lag <= 10 && norm > 0.0; ++lag) {
    double s = 0.0;
    for (Eigen::Index k = std::max<Eigen::Index>(0, lag); k < n && k - lag < n; ++k) s += ec[k] * uc[k - lag];
    if (std::abs(s / norm) > std::abs(r.xcorr_peak)) r.xcorr_peak = s / norm, r.xcorr_lag = lag;
  }

  // Frequency, the linear part: the FRF error where the input explains the residual.
  r.frf_error = frf_error(u, y, e, fs, segment);
  // Frequency, the nonlinear part: odd and even distortion at the empty lines of periodic data.
  r.distortion = periodic_distortion(u, y, e, fs);
  // State: the residual against the input, the simulated output and its integrals.
  r.effective_samples = effective_samples(e);
  const StateSignals states = state_signals(u_all, y_sim_all, fs);
  for (const StateProxy proxy : {StateProxy::input, StateProxy::output, StateProxy::integral, StateProxy::double_integral})
    r.states.push_back(state_profile(to_string(proxy), states.of(proxy).tail(n), e, r.effective_samples));
  return r;
}

namespace {

nlohmann::json frf_error_to_json(const FrfError& f) {
  return {{"frequency_hz", f.frequency_hz}, {"coherence", f.coherence},        {"threshold", f.threshold},
          {"relative_db", number_or_null(f.relative_db)}, {"band_low_hz", f.band_low_hz},
          {"band_high_hz", f.band_high_hz}, {"significant", f.significant}};
}

nlohmann::json distortion_to_json(const PeriodicDistortion& d) {
  return {{"periodic", d.periodic},
          {"period", d.period},
          {"periods", d.periods},
          {"excited_lines", d.excited_lines},
          {"odd_lines_only", d.odd_lines_only},
          {"output_even_db", number_or_null(d.output_even_db)},
          {"output_odd_db", number_or_null(d.output_odd_db)},
          {"residual_even_db", number_or_null(d.residual_even_db)},
          {"residual_odd_db", number_or_null(d.residual_odd_db)},
          {"threshold_db", d.threshold_db}};
}

}  // namespace

nlohmann::json location_to_json(const ResidualLocation& l) {
  nlohmann::json states = nlohmann::json::array();
  for (const StateProfile& p : l.states)
    states.push_back({{"state", p.state},
                      {"centre", std::vector<double>(p.centre.data(), p.centre.data() + p.centre.size())},
                      {"mean", std::vector<double>(p.mean.data(), p.mean.data() + p.mean.size())},
                      {"level_ratio", p.level_ratio},
                      {"shape_chi2", p.shape_chi2},
                      {"direction_t", p.direction_t},
                      {"shape_significant", p.shape_significant},
                      {"direction_significant", p.direction_significant}});
  return {{"noise_psd", l.noise_psd},
          {"noise_floor_pct", l.noise_floor_pct},
          {"noise_floor_relative_sd", l.noise_floor_relative_sd},
          {"residual_pct", l.residual_pct},
          {"peak_frequency_hz", l.peak_frequency_hz},
          {"peak_over_noise", l.peak_over_noise},
          {"peak_threshold", l.peak_threshold},
          {"peak_significant", l.peak_significant},
          {"mean", l.mean},
          {"mean_t", l.mean_t},
          {"level_ratio", l.level_ratio},
          {"drift_ratio", l.drift_ratio},
          {"gain_drift", l.gain_drift},
          {"xcorr_lag", l.xcorr_lag},
          {"xcorr_peak", l.xcorr_peak},
          {"output_level_ratio", l.output_level_ratio},
          {"change_time_s", l.change_time_s},
          {"change_ratio", l.change_ratio},
          {"change_t", l.change_t},
          {"change_significant", l.change_significant},
          {"effective_samples", l.effective_samples},
          {"frf_error", frf_error_to_json(l.frf_error)},
          {"distortion", distortion_to_json(l.distortion)},
          {"states", states}};
}

}  // namespace panelbass::models

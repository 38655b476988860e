#include "dsp/best_linear_approximation.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/FFT>

#include "dsp/random.h"

namespace panelbass::dsp {
namespace {

using Complex = std::complex<double>;
constexpr double nan = std::numeric_limits<double>::quiet_NaN();
// An excited line more than 120 dB below the mean excited line has no power to divide by.
constexpr double kNoPower = 1e-12;

[[noreturn]] void fail(const std::string& what) {
  throw std::invalid_argument("best linear approximation: " + what);
}

// Half spectra (bins 0..N/2) of every steady-state period of one record: spectra[p][k].
std::vector<std::vector<Complex>> period_spectra(const Eigen::VectorXd& x, std::size_t n, std::size_t first,
                                                 std::size_t count, Eigen::FFT<double>& fft) {
  std::vector<std::vector<Complex>> spectra(count);
  std::vector<double> buffer(n);
  for (std::size_t p = 0; p < count; ++p) {
    const Eigen::Index start = static_cast<Eigen::Index>((first + p) * n);
    for (std::size_t i = 0; i < n; ++i) buffer[i] = x[start + static_cast<Eigen::Index>(i)];
    fft.fwd(spectra[p], buffer);
  }
  return spectra;
}

// Output statistics at one non-excited line: level² and noise² of the period-averaged output, per realisation.
struct LinePower {
  double level2 = 0.0;  // mean over m of |Ŷ^[m](k)|²
  double noise2 = 0.0;  // mean over m of σ̂²_Ŷ^[m](k)
};

DetectionLines detection_lines(const std::vector<std::size_t>& lines, const std::vector<LinePower>& power,
                               double n, double fs, std::size_t periods, double threshold_db) {
  DetectionLines d;
  d.lines = lines;
  const Eigen::Index count = static_cast<Eigen::Index>(lines.size());
  d.frequency.resize(count);
  d.level.resize(count);
  d.noise.resize(count);
  double level_sum = 0.0, noise_sum = 0.0;
  for (Eigen::Index i = 0; i < count; ++i) {
    d.frequency[i] = static_cast<double>(lines[static_cast<std::size_t>(i)]) * fs / n;
    // A sine of amplitude a puts N·a/2 in its bin: amplitude = 2|Y|/N.
    d.level[i] = 2.0 / n * std::sqrt(power[static_cast<std::size_t>(i)].level2);
    d.noise[i] = periods >= 2 ? 2.0 / n * std::sqrt(power[static_cast<std::size_t>(i)].noise2) : nan;
    level_sum += d.level[i] * d.level[i];
    noise_sum += d.noise[i] * d.noise[i];
  }
  d.level_to_noise_db = (count > 0 && periods >= 2) ? 10.0 * std::log10(level_sum / noise_sum) : nan;
  d.distortion_detected = d.level_to_noise_db > threshold_db;
  return d;
}

}  // namespace

BestLinearApproximation best_linear_approximation(const std::vector<Eigen::VectorXd>& u,
                                                  const std::vector<Eigen::VectorXd>& y, const BlaSpec& spec) {
  const std::size_t n = spec.period;
  if (n < 4) fail("period must be >= 4 samples, got " + std::to_string(n));
  if (!(spec.fs > 0.0) || !std::isfinite(spec.fs)) fail("fs must be finite and > 0");
  if (u.empty()) fail("no realisations");
  if (u.size() != y.size()) {
    fail(std::to_string(u.size()) + " input records but " + std::to_string(y.size()) + " output records");
  }
  const Eigen::Index length = u[0].size();
  for (std::size_t m = 0; m < u.size(); ++m) {
    const std::string which = "realisation " + std::to_string(m) + ": ";
    if (u[m].size() != length || y[m].size() != length) {
      fail(which + "u has " + std::to_string(u[m].size()) + " samples and y " + std::to_string(y[m].size()) +
           ", realisation 0 has " + std::to_string(length));
    }
    if (!u[m].allFinite() || !y[m].allFinite()) fail(which + "a sample is not finite");
  }
  if (length % static_cast<Eigen::Index>(n) != 0) {
    fail("records of " + std::to_string(length) + " samples are not whole periods of " + std::to_string(n));
  }
  const std::size_t total_periods = static_cast<std::size_t>(length) / n;
  if (total_periods <= spec.transient_periods) {
    fail("records hold " + std::to_string(total_periods) + " periods, none left after " +
         std::to_string(spec.transient_periods) + " transient periods");
  }
  if (spec.excited_lines.empty()) fail("no excited lines");
  if (!(spec.detection_f_max >= 0.0) || !std::isfinite(spec.detection_f_max)) {
    fail("detection_f_max must be finite and >= 0");
  }
  for (std::size_t i = 0; i < spec.excited_lines.size(); ++i) {
    const std::size_t k = spec.excited_lines[i];
    if (k == 0 || 2 * k >= n) fail("excited line " + std::to_string(k) + " not in 0 < k < N/2 = " + std::to_string(n / 2));
    if (i > 0 && k <= spec.excited_lines[i - 1]) fail("excited lines must be strictly ascending");
  }

  const std::size_t big_m = u.size();
  const std::size_t big_p = total_periods - spec.transient_periods;
  const std::size_t lines = spec.excited_lines.size();
  const double dn = static_cast<double>(n), dm = static_cast<double>(big_m), dp = static_cast<double>(big_p);

  // Every line from 1 to the top of the band that is not excited (below the band, difference frequencies
  // land: distortion of both parities), and whether the excitation is odd-only.
  std::size_t k_max = spec.excited_lines.back();
  if (spec.detection_f_max > 0.0) {
    // The band edge given as a bin's rounded frequency still includes that bin.
    const double top = std::floor(spec.detection_f_max * dn / spec.fs + 1e-9);
    k_max = std::max(k_max, std::min(static_cast<std::size_t>(top), (n - 1) / 2));
  }
  bool odd_excitation = true;
  std::vector<bool> excited(n / 2 + 1, false);
  for (const std::size_t k : spec.excited_lines) {
    excited[k] = true;
    odd_excitation = odd_excitation && (k % 2 == 1);
  }
  std::vector<std::size_t> empty_lines;
  for (std::size_t k = 1; k <= k_max; ++k) {
    if (!excited[k]) empty_lines.push_back(k);
  }

  BestLinearApproximation r;
  r.realisations = big_m;
  r.periods = big_p;
  r.lines = spec.excited_lines;
  r.frequency.resize(static_cast<Eigen::Index>(lines));
  for (std::size_t i = 0; i < lines; ++i) {
    r.frequency[static_cast<Eigen::Index>(i)] = static_cast<double>(spec.excited_lines[i]) * spec.fs / dn;
  }

  Eigen::MatrixXcd g_m(static_cast<Eigen::Index>(lines), static_cast<Eigen::Index>(big_m));  // Ĝ^[m](k)
  Eigen::VectorXd noise_sum = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(lines));
  Eigen::VectorXd output_power = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(lines));
  std::vector<LinePower> empty_power(empty_lines.size());
  Eigen::FFT<double> fft;
  fft.SetFlag(Eigen::FFT<double>::HalfSpectrum);
  std::vector<Complex> g_p(big_p);

  for (std::size_t m = 0; m < big_m; ++m) {
    const auto us = period_spectra(u[m], n, spec.transient_periods, big_p, fft);
    const auto ys = period_spectra(y[m], n, spec.transient_periods, big_p, fft);
    // Mean |U(k)|² over the excited lines of each period: the reference for "no power at a line".
    std::vector<double> excited_power(big_p, 0.0);
    for (std::size_t p = 0; p < big_p; ++p) {
      for (const std::size_t k : spec.excited_lines) excited_power[p] += std::norm(us[p][k]) / static_cast<double>(lines);
    }
    for (std::size_t i = 0; i < lines; ++i) {
      const std::size_t k = spec.excited_lines[i];
      // G^[m,p](k) = Y^[m,p](k)/U^[m,p](k);  Ĝ^[m](k) = (1/P)·Σ_p G^[m,p](k)
      Complex mean = 0.0, y_mean = 0.0;
      for (std::size_t p = 0; p < big_p; ++p) {
        if (!(std::norm(us[p][k]) > kNoPower * excited_power[p])) {
          fail("realisation " + std::to_string(m) + ", period " + std::to_string(p) + ": no input power at line " +
               std::to_string(k));
        }
        g_p[p] = ys[p][k] / us[p][k];
        mean += g_p[p];
        y_mean += ys[p][k];
      }
      mean /= dp;
      y_mean /= dp;
      g_m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(m)) = mean;
      output_power[static_cast<Eigen::Index>(i)] += std::norm(y_mean) / dm;
      // σ̂²_n^[m](k) = Σ_p |G^[m,p](k) − Ĝ^[m](k)|² / (P·(P−1)), the noise variance of Ĝ^[m](k)
      if (big_p >= 2) {
        double s = 0.0;
        for (std::size_t p = 0; p < big_p; ++p) s += std::norm(g_p[p] - mean);
        noise_sum[static_cast<Eigen::Index>(i)] += s / (dp * (dp - 1.0));
      }
    }
    for (std::size_t j = 0; j < empty_lines.size(); ++j) {
      const std::size_t k = empty_lines[j];
      // Ŷ^[m](k) = (1/P)·Σ_p Y^[m,p](k);  σ̂²_Ŷ^[m](k) = Σ_p |Y^[m,p](k) − Ŷ^[m](k)|² / (P·(P−1))
      Complex mean = 0.0;
      for (std::size_t p = 0; p < big_p; ++p) mean += ys[p][k];
      mean /= dp;
      double s = 0.0;
      for (std::size_t p = 0; p < big_p; ++p) s += std::norm(ys[p][k] - mean);
      empty_power[j].level2 += std::norm(mean) / dm;
      if (big_p >= 2) empty_power[j].noise2 += s / (dp * (dp - 1.0)) / dm;
    }
  }

  // G_BLA(k) = (1/M)·Σ_m Ĝ^[m](k)
  r.g = g_m.rowwise().mean();
  // σ̂²_n(k) = (1/M²)·Σ_m σ̂²_n^[m](k)            (noise variance of G_BLA)
  // σ̂²_BLA(k) = Σ_m |Ĝ^[m](k) − G_BLA(k)|² / (M·(M−1))   (total variance of G_BLA)
  // σ̂²_s(k) = σ̂²_BLA(k) − σ̂²_n(k)                (stochastic nonlinear distortion on G_BLA)
  r.noise_variance = big_p >= 2 ? Eigen::VectorXd(noise_sum / (dm * dm))
                                : Eigen::VectorXd::Constant(static_cast<Eigen::Index>(lines), nan);
  r.total_variance.resize(static_cast<Eigen::Index>(lines));
  r.nonlinear_variance.resize(static_cast<Eigen::Index>(lines));
  for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(lines); ++i) {
    if (big_m >= 2) {
      r.total_variance[i] = (g_m.row(i).array() - r.g[i]).abs2().sum() / (dm * (dm - 1.0));
    } else {
      r.total_variance[i] = nan;
    }
    r.nonlinear_variance[i] = std::max(r.total_variance[i] - r.noise_variance[i], 0.0);
    if (std::isnan(r.total_variance[i]) || std::isnan(r.noise_variance[i])) r.nonlinear_variance[i] = nan;
  }
  r.output_level = 2.0 / dn * output_power.cwiseSqrt();

  if (odd_excitation) {
    std::vector<std::size_t> even_lines, odd_lines;
    std::vector<LinePower> even_power, odd_power;
    for (std::size_t j = 0; j < empty_lines.size(); ++j) {
      const bool even = empty_lines[j] % 2 == 0;
      (even ? even_lines : odd_lines).push_back(empty_lines[j]);
      (even ? even_power : odd_power).push_back(empty_power[j]);
    }
    r.even = detection_lines(even_lines, even_power, dn, spec.fs, big_p, spec.detection_threshold_db);
    r.odd = detection_lines(odd_lines, odd_power, dn, spec.fs, big_p, spec.detection_threshold_db);
  }
  return r;
}

MultisineRealisations multisine_realisations(const MultisineSpec& spec, std::size_t realisations) {
  if (realisations == 0) throw std::invalid_argument("multisine realisations: need at least 1 realisation");
  const Multisine first = multisine(spec);
  MultisineRealisations r;
  r.lines = first.lines;
  r.detection_lines = first.detection_lines;
  r.signals.push_back(first.signal);

  const std::size_t n = spec.period;
  Eigen::FFT<double> fft;
  for (std::size_t m = 1; m < realisations; ++m) {
    // x(t) = Σ_k cos(2π·k·t/N + φ_k), φ_k uniform in [0, 2π), by inverse FFT of a Hermitian spectrum;
    // then scaled to the requested peak as multisine() does.
    Rng rng(spec.seed ^ (0x9E3779B97F4A7C15ULL * static_cast<std::uint64_t>(m)));
    std::vector<Complex> spectrum(n, Complex(0.0, 0.0));
    for (const std::size_t k : r.lines) {
      const Complex line = std::polar(1.0, rng.uniform(0.0, 2.0 * std::numbers::pi));
      spectrum[k] = line;
      spectrum[n - k] = std::conj(line);
    }
    std::vector<Complex> time;
    fft.inv(time, spectrum);
    Eigen::VectorXd period(static_cast<Eigen::Index>(n));
    for (std::size_t i = 0; i < n; ++i) period[static_cast<Eigen::Index>(i)] = time[i].real();
    period *= spec.amplitude / period.cwiseAbs().maxCoeff();
    period = period.cwiseMax(-spec.amplitude).cwiseMin(spec.amplitude);
    r.signals.push_back(period.replicate(static_cast<Eigen::Index>(spec.periods), 1));
  }
  return r;
}

}  // namespace panelbass::dsp

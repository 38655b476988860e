#include "dsp/harmonics.h"

#include <algorithm>

#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "dsp/period.h"

namespace panelbass::dsp {

double HarmonicLevels::thd_percent() const {
  if (amplitude.empty() || !(amplitude[0] > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (std::size_t h = 1; h < amplitude.size(); ++h) sum += amplitude[h] * amplitude[h];
  return 100.0 * std::sqrt(sum) / amplitude[0];
}

double HarmonicLevels::relative_db(std::size_t h) const {
  if (h < 1 || h > amplitude.size()) throw std::out_of_range("harmonic " + std::to_string(h) + " not measured");
  return 20.0 * std::log10(amplitude[h - 1] / amplitude[0]);
}

std::complex<double> HarmonicLevels::relative(std::size_t h) const {
  if (h < 1 || h > amplitude.size() || h > phase.size()) {
    throw std::out_of_range("harmonic " + std::to_string(h) + " not measured");
  }
  return std::polar(amplitude[h - 1] / amplitude[0], phase[h - 1] - static_cast<double>(h) * phase[0]);
}

HarmonicLevels harmonic_levels(const Eigen::VectorXd& x, double fs, double frequency, int max_order) {
  if (x.size() < 2) throw std::invalid_argument("harmonic levels: need at least 2 samples");
  if (!(frequency > 0.0 && frequency < fs / 2.0)) {
    throw std::invalid_argument("harmonic levels: frequency must be within (0, fs/2)");
  }
  HarmonicLevels out;
  out.frequency = frequency;
  const double n = static_cast<double>(x.size());
  for (int h = 1; h <= max_order && h * frequency < fs / 2.0; ++h) {
    // Single-bin DFT: a_h·e^{jφ_h} = (2/N)·Σ x(k)·e^{−j2π·h·f·k/fs}
    std::complex<double> sum = 0.0;
    const double w = 2.0 * std::numbers::pi * h * frequency / fs;
    for (Eigen::Index k = 0; k < x.size(); ++k) sum += x[k] * std::polar(1.0, -w * static_cast<double>(k));
    out.amplitude.push_back(2.0 * std::abs(sum) / n);
    out.phase.push_back(std::arg(sum));
  }
  return out;
}

namespace {

// steady_thd_percent's stretch: the last three quarters, cut to whole periods; 0 when fewer than 4 fit.
Eigen::Index steady_length(const Eigen::VectorXd& y, double fs, double frequency) {
  const Eigen::Index start = y.size() / 4;
  const double period = fs / frequency;
  const auto most = static_cast<long>(std::floor(static_cast<double>(y.size() - start) / period));
  if (most < 4) return 0;
  const long periods = closest_whole_periods(period, most, std::max(4L, most / 2));
  return std::min<Eigen::Index>(static_cast<Eigen::Index>(std::llround(static_cast<double>(periods) * period)),
                                y.size() - start);
}

}  // namespace

std::optional<double> steady_thd_percent(const Eigen::VectorXd& y, double fs, double frequency, int max_order) {
  const Eigen::Index length = steady_length(y, fs, frequency);
  if (length == 0) return std::nullopt;
  const double thd = harmonic_levels(y.tail(length), fs, frequency, max_order).thd_percent();
  if (!std::isfinite(thd)) return std::nullopt;
  return thd;
}

std::optional<SteadyThd> steady_thd(const Eigen::VectorXd& y, double fs, double frequency, int max_order) {
  const Eigen::Index length = steady_length(y, fs, frequency);
  if (length == 0) return std::nullopt;
  const Eigen::VectorXd x = y.tail(length);
  const HarmonicLevels levels = harmonic_levels(x, fs, frequency, max_order);
  const double measured = levels.thd_percent();
  if (!std::isfinite(measured)) return std::nullopt;
  // The residual: the stretch less its mean and Σ_h a_h·cos(2π·h·f·k/fs + φ_h).
  Eigen::VectorXd residual = x.array() - x.mean();
  for (std::size_t h = 0; h < levels.amplitude.size(); ++h) {
    const double w = 2.0 * std::numbers::pi * static_cast<double>(h + 1) * frequency / fs;
    for (Eigen::Index k = 0; k < length; ++k) {
      residual[k] -= levels.amplitude[h] * std::cos(w * static_cast<double>(k) + levels.phase[h]);
    }
  }
  const auto harmonics = static_cast<double>(levels.amplitude.size());
  const double n = static_cast<double>(length);
  const double sigma2 = residual.squaredNorm() / std::max(1.0, n - 1.0 - 2.0 * harmonics);
  const double per_bin = 4.0 * sigma2 / n;  // the noise's mean square in one single-bin amplitude
  const double count = harmonics - 1.0;     // the harmonics above the fundamental
  double power = 0.0;
  for (std::size_t h = 1; h < levels.amplitude.size(); ++h) power += levels.amplitude[h] * levels.amplitude[h];
  const double a1 = levels.amplitude[0];
  SteadyThd out;
  out.measured_thd_pct = measured;
  out.fundamental = a1;
  out.samples = length;
  out.floor_pct = 100.0 * std::sqrt(count * per_bin) / a1;
  const double clean = std::max(0.0, power - count * per_bin);
  out.thd_pct = 100.0 * std::sqrt(clean) / a1;
  // |A + n|² with n of mean square F has variance 2|A|²F + F²; in dB of the root, (10/ln 10)·σ(P)/P.
  out.uncertainty_db = clean > 0.0 ? 10.0 / std::numbers::ln10 * std::sqrt(2.0 * clean * per_bin + count * per_bin * per_bin) / clean
                                   : std::numeric_limits<double>::infinity();
  out.at_floor = power < 2.0 * count * per_bin;
  return out;
}

}  // namespace panelbass::dsp

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

std::optional<double> steady_thd_percent(const Eigen::VectorXd& y, double fs, double frequency, int max_order) {
  const Eigen::Index start = y.size() / 4;
  const double period = fs / frequency;
  const auto most = static_cast<long>(std::floor(static_cast<double>(y.size() - start) / period));
  if (most < 4) return std::nullopt;
  const long periods = closest_whole_periods(period, most, std::max(4L, most / 2));
  const auto length = std::min<Eigen::Index>(
      static_cast<Eigen::Index>(std::llround(static_cast<double>(periods) * period)), y.size() - start);
  const double thd = harmonic_levels(y.tail(length), fs, frequency, max_order).thd_percent();
  if (!std::isfinite(thd)) return std::nullopt;
  return thd;
}

}  // namespace panelbass::dsp

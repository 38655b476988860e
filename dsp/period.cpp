#include "dsp/period.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <unsupported/Eigen/FFT>
#include <vector>

namespace panelbass::dsp {

Eigen::Index find_period(const Eigen::VectorXd& x, const PeriodSearch& search) {
  const Eigen::Index n = x.size();
  const Eigen::Index repeats = std::max<Eigen::Index>(2, search.min_repeats);
  const Eigen::Index longest = n / repeats;
  const Eigen::Index shortest = std::max<Eigen::Index>(1, search.min_period);
  if (longest < shortest) return 0;
  const Eigen::VectorXd xc = x.array() - x.mean();
  const double variance = xc.squaredNorm() / static_cast<double>(n);
  // A constant (up to the rounding of its mean) does not repeat; neither does a signal that is not finite.
  if (!(variance > 1e-20 * x.squaredNorm() / static_cast<double>(n)) || !std::isfinite(variance)) return 0;

  // R(P) = Σ_k xc(k)·xc(k+P) by one zero-padded FFT.
  Eigen::Index padded = 1;
  while (padded < 2 * n) padded *= 2;
  std::vector<double> time(static_cast<std::size_t>(padded), 0.0);
  std::copy(xc.data(), xc.data() + n, time.begin());
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> spectrum;
  fft.fwd(spectrum, time);
  for (auto& c : spectrum) c = std::norm(c);
  std::vector<double> correlation;
  fft.inv(correlation, spectrum);

  // Σ_{k<n−P} (xc(k+P) − xc(k))² = Σ tail² + Σ head² − 2R(P), the energies from cumulative sums.
  std::vector<double> cumulative(static_cast<std::size_t>(n) + 1, 0.0);
  for (Eigen::Index k = 0; k < n; ++k) cumulative[static_cast<std::size_t>(k) + 1] = cumulative[static_cast<std::size_t>(k)] + xc[k] * xc[k];
  const auto relative_difference = [&](Eigen::Index p) {
    const auto m = static_cast<std::size_t>(n - p);
    const double head = cumulative[m];
    const double tail = cumulative[static_cast<std::size_t>(n)] - cumulative[static_cast<std::size_t>(p)];
    const double squared = std::max(0.0, head + tail - 2.0 * correlation[static_cast<std::size_t>(p)]);
    return std::sqrt(squared / static_cast<double>(m) / variance);
  };
  std::vector<double> difference(static_cast<std::size_t>(longest) + 2, 0.0);
  for (Eigen::Index p = std::max<Eigen::Index>(1, shortest - 1); p <= std::min(longest + 1, n - 1); ++p)
    difference[static_cast<std::size_t>(p)] = relative_difference(p);
  double smallest = difference[static_cast<std::size_t>(shortest)];
  for (Eigen::Index p = shortest; p <= longest; ++p) smallest = std::min(smallest, difference[static_cast<std::size_t>(p)]);
  // Rounding leaves ~1e-8 of an exact repeat; twice the smallest plus that is "as good as the best".
  const double accept = std::min(search.tolerance, 2.0 * smallest + 1e-6);
  for (Eigen::Index p = shortest; p <= longest; ++p) {
    const double d = difference[static_cast<std::size_t>(p)];
    const bool local_minimum = (p == shortest || d <= difference[static_cast<std::size_t>(p) - 1]) &&
                               (p + 1 > n - 1 || d <= difference[static_cast<std::size_t>(p) + 1]);
    if (d <= accept && local_minimum) return p;
  }
  return 0;
}

long closest_whole_periods(double period, long most, long least) {
  long best = std::max(most, least);
  double best_miss = 1.0;
  for (long m = most; m >= least; --m) {
    const double length = static_cast<double>(m) * period;
    const double miss = std::abs(length - std::round(length));
    if (miss < best_miss - 1e-12) {
      best = m;
      best_miss = miss;
    }
  }
  return best;
}

}  // namespace panelbass::dsp

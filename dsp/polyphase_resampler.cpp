#include "dsp/polyphase_resampler.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <string>
#include <Eigen/Core>
#include <unsupported/Eigen/FFT>

namespace panelbass::dsp {
namespace {

constexpr long kMaxFactor = 1000;

long whole_rate(double hz, const char* what) {
  if (!(std::isfinite(hz) && hz >= 1.0 && hz <= 1e7 && hz == std::round(hz))) {
    throw std::invalid_argument(std::string("low-latency resampler: ") + what + " rate must be a whole number of Hz in [1, 1e7], got " +
                                std::to_string(hz));
  }
  return static_cast<long>(hz);
}

/// Kaiser's window parameter for `a` dB of stop-band rejection (Kaiser 1974, in O&S eq. 7.75).
double kaiser_beta(double a) {
  if (a > 50.0) return 0.1102 * (a - 8.7);
  if (a >= 21.0) return 0.5842 * std::pow(a - 21.0, 0.4) + 0.07886 * (a - 21.0);
  return 0.0;
}

/// The minimum-phase filter with the magnitude response of `h`, as long as `h`: the real cepstrum of
/// |H| folded onto positive quefrencies (O&S §13.5.3: ĉ[n] = c[0], 2c[n], c[N/2], 0 for n = 0, 0<n<N/2,
/// N/2, n>N/2), exponentiated back.
std::vector<double> minimum_phase(const std::vector<double>& h, double floor) {
  std::size_t n = 4096;
  while (n < 16 * h.size()) n *= 2;
  Eigen::FFT<double> fft;
  std::vector<double> padded(n, 0.0);
  std::copy(h.begin(), h.end(), padded.begin());
  std::vector<std::complex<double>> spectrum;
  fft.fwd(spectrum, padded);
  std::vector<std::complex<double>> log_magnitude(n);
  for (std::size_t k = 0; k < n; ++k) log_magnitude[k] = std::log(std::max(std::abs(spectrum[k]), floor));
  std::vector<std::complex<double>> cepstrum;
  fft.inv(cepstrum, log_magnitude);
  for (std::size_t q = 1; q < n / 2; ++q) {
    cepstrum[q] *= 2.0;
    cepstrum[n - q] = 0.0;
  }
  std::vector<std::complex<double>> folded;
  fft.fwd(folded, cepstrum);
  for (auto& z : folded) z = std::exp(z);
  std::vector<std::complex<double>> impulse;
  fft.inv(impulse, folded);
  std::vector<double> out(h.size());
  for (std::size_t k = 0; k < out.size(); ++k) out[k] = impulse[k].real();
  return out;
}

}  // namespace

LowLatencyFilter design_low_latency_filter(double from, double to, const LowLatencySpec& spec) {
  const long f = whole_rate(from, "input"), t = whole_rate(to, "output");
  if (!(spec.passband > 0.0 && spec.passband < 1.0)) {
    throw std::invalid_argument("low-latency resampler: passband must be in (0, 1) of the lower Nyquist, got " +
                                std::to_string(spec.passband));
  }
  if (!(spec.attenuation_db >= 21.0 && spec.attenuation_db <= 160.0)) {
    throw std::invalid_argument("low-latency resampler: attenuation_db must be in [21, 160], got " +
                                std::to_string(spec.attenuation_db));
  }
  const long g = std::gcd(f, t);
  LowLatencyFilter filter;
  filter.up = static_cast<int>(t / g);
  filter.down = static_cast<int>(f / g);
  if (filter.up > kMaxFactor || filter.down > kMaxFactor) {
    throw std::invalid_argument("low-latency resampler: " + std::to_string(f) + " Hz -> " + std::to_string(t) + " Hz is " +
                                std::to_string(filter.up) + "/" + std::to_string(filter.down) +
                                " in lowest terms; both must be <= 1000");
  }
  const double fs = static_cast<double>(filter.up) * static_cast<double>(f);
  const double nyquist = 0.5 * static_cast<double>(std::min(f, t));
  filter.prototype_rate = fs;
  filter.pass_hz = spec.passband * nyquist;
  filter.stop_hz = (2.0 - spec.passband) * nyquist;
  // Designed 6 dB beyond the specification: truncating the minimum-phase taps to the linear-phase
  // length costs a few dB of rejection and ripple; the margin keeps the specification met.
  const double a = spec.attenuation_db + 6.0;
  // Kaiser's length for a transition of Δω rad/sample: N − 1 = (A − 7.95) / (2.285 Δω) (O&S eq. 7.76).
  const double dw = 2.0 * std::numbers::pi * (filter.stop_hz - filter.pass_hz) / fs;
  auto length = static_cast<std::size_t>(std::ceil((a - 7.95) / (2.285 * dw))) + 1;
  const auto up = static_cast<std::size_t>(filter.up);
  length = (length + up - 1) / up * up;
  // The linear-phase prototype: h[k] = 2fc/fs · sinc(2fc/fs · (k − (N−1)/2)) · w[k], fc mid-transition.
  const double fc = 0.5 * (filter.pass_hz + filter.stop_hz) / fs;
  const double beta = kaiser_beta(a), i0_beta = std::cyl_bessel_i(0.0, beta);
  const double centre = 0.5 * static_cast<double>(length - 1);
  std::vector<double> h(length);
  for (std::size_t k = 0; k < length; ++k) {
    const double x = static_cast<double>(k) - centre;
    const double sinc = x == 0.0 ? 1.0 : std::sin(2.0 * std::numbers::pi * fc * x) / (2.0 * std::numbers::pi * fc * x);
    const double r = x / centre;
    const double w = std::cyl_bessel_i(0.0, beta * std::sqrt(std::max(0.0, 1.0 - r * r))) / i0_beta;
    h[k] = 2.0 * fc * sinc * w;
  }
  filter.taps = minimum_phase(h, 1e-3 * std::pow(10.0, -a / 20.0));
  const double dc = std::accumulate(filter.taps.begin(), filter.taps.end(), 0.0);
  double moment = 0.0;
  for (std::size_t k = 0; k < filter.taps.size(); ++k) {
    filter.taps[k] /= dc;
    moment += static_cast<double>(k) * filter.taps[k];
  }
  filter.delay_s = moment / fs;
  filter.ripple_db = 20.0 * std::log10(1.0 + 2.0 * std::pow(10.0, -spec.attenuation_db / 20.0));
  return filter;
}

PolyphaseResampler::PolyphaseResampler(double from, double to, int channels, int max_input, const LowLatencySpec& spec)
    : filter_(design_low_latency_filter(from, to, spec)), channels_(channels) {
  if (channels < 1 || max_input < 1) {
    throw std::invalid_argument("low-latency resampler: channels and max_input must be >= 1, got " +
                                std::to_string(channels) + " and " + std::to_string(max_input));
  }
  const auto up = static_cast<std::size_t>(filter_.up), down = static_cast<std::size_t>(filter_.down);
  max_input_ = static_cast<std::size_t>(max_input);
  max_output_ = (max_input_ * up + down - 1) / down + 1;
  taps_per_phase_ = filter_.taps.size() / up;
  // Polyphase decomposition: y[m] = L Σ_j h[p + L·j] x[i₀ − j], i₀ = ⌊mM/L⌋, p = mM − L·i₀ (the
  // zero-stuffed input's convolution with h, keeping only the non-zero products).
  bank_.resize(up * taps_per_phase_);
  for (std::size_t p = 0; p < up; ++p) {
    for (std::size_t j = 0; j < taps_per_phase_; ++j) bank_[p * taps_per_phase_ + j] = static_cast<double>(up) * filter_.taps[p + up * j];
  }
  history_.assign(static_cast<std::size_t>(channels) * 2 * taps_per_phase_, 0.0);
  out_.assign(static_cast<std::size_t>(channels) * max_output_, 0.0);
}

void PolyphaseResampler::reset() noexcept {
  std::fill(history_.begin(), history_.end(), 0.0);
  head_ = 0;
  inputs_ = 0;
  next_input_ = 0;
  next_phase_ = 0;
  produced_ = 0;
}

std::size_t PolyphaseResampler::process(std::span<const std::span<const double>> in) noexcept {
  produced_ = 0;
  if (in.size() != static_cast<std::size_t>(channels_)) return 0;
  const std::size_t frames = std::min(in[0].size(), max_input_);
  const std::size_t t = taps_per_phase_;
  for (std::size_t k = 0; k < frames; ++k) {
    // Newest first: the ring's window [head, head + T) holds x[i], x[i−1], …, written twice so that the
    // window never wraps.
    head_ = head_ == 0 ? t - 1 : head_ - 1;
    for (std::size_t c = 0; c < in.size(); ++c) {
      double* ring = history_.data() + c * 2 * t;
      ring[head_] = ring[head_ + t] = in[c][k];
    }
    const std::int64_t current = inputs_++;
    while (next_input_ == current && produced_ < max_output_) {
      const double* taps = bank_.data() + static_cast<std::size_t>(next_phase_) * t;
      for (std::size_t c = 0; c < in.size(); ++c) {
        const double* window = history_.data() + c * 2 * t + head_;
        // Eigen's dot product runs in SIMD packets (a few partial sums), unlike std::inner_product.
        out_[c * max_output_ + produced_] = Eigen::Map<const Eigen::VectorXd>(taps, static_cast<Eigen::Index>(t))
                                                .dot(Eigen::Map<const Eigen::VectorXd>(window, static_cast<Eigen::Index>(t)));
      }
      ++produced_;
      next_phase_ += filter_.down;
      next_input_ += next_phase_ / filter_.up;
      next_phase_ %= filter_.up;
    }
  }
  return produced_;
}

}  // namespace panelbass::dsp

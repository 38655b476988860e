#include "dsp/excitation.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/FFT>

#include "dsp/random.h"

namespace panelbass::dsp {
namespace {

constexpr double two_pi = 2.0 * std::numbers::pi;

[[noreturn]] void fail(const char* where, const std::string& what, double value) {
  std::ostringstream message;
  message.precision(17);
  message << where << ": " << what << ", got " << value;
  throw std::invalid_argument(message.str());
}

void check_samples(const char* where, const char* name, std::size_t samples) {
  if (samples == 0) {
    fail(where, std::string(name) + " must be > 0", 0.0);
  }
}

void check_amplitude(const char* where, double amplitude) {
  if (!std::isfinite(amplitude) || amplitude <= 0.0) {
    fail(where, "amplitude must be finite and > 0", amplitude);
  }
}

void check_fs(const char* where, double fs) {
  if (!std::isfinite(fs) || fs <= 0.0) {
    fail(where, "fs must be finite and > 0", fs);
  }
}

// A tone must lie strictly between DC and Nyquist: at either end a sine has no power to measure.
void check_tone(const char* where, const char* name, double frequency, double fs) {
  if (!std::isfinite(frequency) || frequency <= 0.0 || frequency >= fs / 2.0) {
    fail(where, std::string(name) + " must satisfy 0 < " + name + " < fs/2 = " +
                    std::to_string(fs / 2.0),
         frequency);
  }
}

}  // namespace

Eigen::VectorXd uniform_noise(std::size_t samples, double amplitude, std::uint64_t seed) {
  check_samples("uniform_noise", "samples", samples);
  check_amplitude("uniform_noise", amplitude);
  Rng rng(seed);
  Eigen::VectorXd x(static_cast<Eigen::Index>(samples));
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    x[i] = rng.uniform(-amplitude, amplitude);
  }
  return x;
}

Eigen::VectorXd gaussian_noise(std::size_t samples, double amplitude, std::uint64_t seed) {
  check_samples("gaussian_noise", "samples", samples);
  check_amplitude("gaussian_noise", amplitude);
  Rng rng(seed);
  const double sigma = amplitude / 3.0;
  Eigen::VectorXd x(static_cast<Eigen::Index>(samples));
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    // Redrawing (about 0.27 % of draws at 3σ) keeps the drive in range without clipping, which
    // would put spikes of probability mass at ±amplitude.
    double v = 0.0;
    do {
      v = sigma * rng.gaussian();
    } while (std::abs(v) > amplitude);
    x[i] = v;
  }
  return x;
}

Multisine multisine(const MultisineSpec& spec) {
  constexpr const char* where = "multisine";
  if (spec.period < 4) {
    fail(where, "period must be >= 4", static_cast<double>(spec.period));
  }
  if (spec.periods == 0) {
    fail(where, "periods must be > 0", 0.0);
  }
  check_fs(where, spec.fs);
  check_amplitude(where, spec.amplitude);
  if (!std::isfinite(spec.f_min) || spec.f_min < 0.0) {
    fail(where, "f_min must be finite and >= 0", spec.f_min);
  }
  if (!std::isfinite(spec.f_max) || spec.f_max > spec.fs / 2.0) {
    fail(where, "f_max must be finite and <= fs/2 = " + std::to_string(spec.fs / 2.0), spec.f_max);
  }
  if (spec.f_max < spec.f_min) {
    fail(where, "f_max must be >= f_min = " + std::to_string(spec.f_min), spec.f_max);
  }
  if (spec.lines == MultisineLines::random_odd && spec.group < 2) {
    fail(where, "group must be >= 2 for random_odd", static_cast<double>(spec.group));
  }

  // Candidate lines: 0 < k < period/2 (DC and Nyquist carry no phase freedom) with k·fs/N in the
  // band; a band edge given as a rounded bin frequency still includes that bin.
  const std::size_t n = spec.period;
  const double df = spec.fs / static_cast<double>(n);
  const double tolerance = 1e-9 * df;
  std::vector<std::size_t> candidates;
  for (std::size_t k = 1; 2 * k < n; ++k) {
    const double f = static_cast<double>(k) * df;
    if (f < spec.f_min - tolerance || f > spec.f_max + tolerance) {
      continue;
    }
    if (spec.lines != MultisineLines::all && k % 2 == 0) {
      continue;
    }
    candidates.push_back(k);
  }

  Rng rng(spec.seed);
  Multisine result;
  if (spec.lines == MultisineLines::random_odd) {
    // One line left out of each complete group of `group` consecutive odd lines; a trailing
    // incomplete group is fully excited. The empty lines show odd-order distortion (detection).
    const std::size_t full = candidates.size() - candidates.size() % spec.group;
    for (std::size_t start = 0; start < candidates.size(); start += spec.group) {
      const std::size_t skip =
          start < full ? start + static_cast<std::size_t>(rng.below(spec.group)) : candidates.size();
      for (std::size_t i = start; i < std::min(start + spec.group, candidates.size()); ++i) {
        (i == skip ? result.detection_lines : result.lines).push_back(candidates[i]);
      }
    }
  } else {
    result.lines = candidates;
  }
  if (result.lines.empty()) {
    fail(where, "no DFT line lies in [f_min, f_max]; f_max", spec.f_max);
  }

  // One period by inverse FFT of unit-magnitude lines with random phases (Hermitian spectrum, so
  // the period is real), then tiled: every period is the same bits.
  std::vector<std::complex<double>> spectrum(n, {0.0, 0.0});
  for (const std::size_t k : result.lines) {
    const std::complex<double> line = std::polar(1.0, rng.uniform(0.0, two_pi));
    spectrum[k] = line;
    spectrum[n - k] = std::conj(line);
  }
  std::vector<std::complex<double>> time;
  Eigen::FFT<double> fft;
  fft.inv(time, spectrum);

  Eigen::VectorXd period(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    period[static_cast<Eigen::Index>(i)] = time[i].real();
  }
  Eigen::Index peak_index = 0;
  const double peak = period.cwiseAbs().maxCoeff(&peak_index);
  period *= spec.amplitude / peak;
  // Rounding of the scale can leave the peak an ulp off; pin it so max |x| is the amplitude exactly.
  period = period.cwiseMax(-spec.amplitude).cwiseMin(spec.amplitude);
  period[peak_index] = std::copysign(spec.amplitude, period[peak_index]);

  result.signal = period.replicate(static_cast<Eigen::Index>(spec.periods), 1);
  return result;
}

Eigen::VectorXd log_sweep(std::size_t samples, double fs, double f_start, double f_stop,
                          double amplitude) {
  constexpr const char* where = "log_sweep";
  check_samples(where, "samples", samples);
  check_fs(where, fs);
  check_tone(where, "f_start", f_start, fs);
  check_tone(where, "f_stop", f_stop, fs);
  if (f_start == f_stop) {
    fail(where, "f_stop must differ from f_start", f_stop);
  }
  check_amplitude(where, amplitude);
  // Farina's exponential sweep: x(t) = A sin(2π f1 L (e^{t/L} − 1)), L = T / ln(f2/f1), whose
  // instantaneous frequency f1 e^{t/L} runs from f1 at t = 0 to f2 at t = T = samples/fs.
  const double duration = static_cast<double>(samples) / fs;
  const double rate = duration / std::log(f_stop / f_start);
  Eigen::VectorXd x(static_cast<Eigen::Index>(samples));
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double t = static_cast<double>(i) / fs;
    x[i] = amplitude * std::sin(two_pi * f_start * rate * std::expm1(t / rate));
  }
  return x;
}

Eigen::VectorXd sine(std::size_t samples, double fs, double frequency, double amplitude) {
  constexpr const char* where = "sine";
  check_samples(where, "samples", samples);
  check_fs(where, fs);
  check_tone(where, "frequency", frequency, fs);
  check_amplitude(where, amplitude);
  Eigen::VectorXd x(static_cast<Eigen::Index>(samples));
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    x[i] = amplitude * std::sin(two_pi * frequency * static_cast<double>(i) / fs);
  }
  return x;
}

SteppedSine stepped_sine(const SteppedSineSpec& spec) {
  constexpr const char* where = "stepped_sine";
  check_fs(where, spec.fs);
  check_amplitude(where, spec.amplitude);
  if (spec.frequencies.empty()) {
    fail(where, "frequencies must not be empty; size", 0.0);
  }
  if (spec.measure < 3) {
    fail(where, "measure must be >= 3 (room for one bin below Nyquist)",
         static_cast<double>(spec.measure));
  }
  const double measure = static_cast<double>(spec.measure);
  const std::size_t highest_bin = (spec.measure - 1) / 2;  // largest j with 2j < measure
  const std::size_t step_length = spec.settle + spec.measure;

  SteppedSine result;
  result.signal.resize(static_cast<Eigen::Index>(step_length * spec.frequencies.size()));
  double phase = 0.0;  // radians at the first sample of the current step, kept in [0, 2π)
  std::size_t start = 0;
  for (const double requested : spec.frequencies) {
    check_tone(where, "frequency", requested, spec.fs);
    // Whole periods in the measured window put the tone and its harmonics exactly on DFT bins.
    const double bin = std::round(requested * measure / spec.fs);
    const double j = std::clamp(bin, 1.0, static_cast<double>(highest_bin));
    const double frequency = j * spec.fs / measure;
    const double increment = two_pi * frequency / spec.fs;
    // Phase from the step's start rather than a running sum, so rounding does not accumulate.
    for (std::size_t i = 0; i < step_length; ++i) {
      result.signal[static_cast<Eigen::Index>(start + i)] =
          spec.amplitude * std::sin(phase + increment * static_cast<double>(i));
    }
    result.steps.push_back(SineStep{frequency, start + spec.settle, spec.measure});
    phase = std::fmod(phase + increment * static_cast<double>(step_length), two_pi);
    start += step_length;
  }
  return result;
}

}  // namespace panelbass::dsp

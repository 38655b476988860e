#include "dsp/butterworth.h"

#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

namespace panelbass::dsp {
namespace {

[[noreturn]] void fail(const std::string& where, const std::string& what, double value) {
  std::ostringstream message;
  message.precision(17);
  message << where << ": " << what << ", got " << value;
  throw std::invalid_argument(message.str());
}

void check_order(const char* where, int order) {
  if (order < 1 || order > 16) {
    fail(where, "order must be in 1..16", order);
  }
}

void check_digital(const char* where, const char* name, double cutoff_hz, double fs) {
  if (!std::isfinite(fs) || fs <= 0.0) {
    fail(where, "fs must be finite and > 0", fs);
  }
  if (!std::isfinite(cutoff_hz) || cutoff_hz <= 0.0 || cutoff_hz >= fs / 2.0) {
    fail(where, std::string(name) + " must satisfy 0 < " + name + " < fs/2 = " +
                    std::to_string(fs / 2.0),
         cutoff_hz);
  }
}

// The normalised prototype's quality factors: for order n the poles sit at angles
// θ_k = (2k−1)π/(2n) from the imaginary axis, and a conjugate pair gives s² + 2 sin(θ_k) s + 1,
// i.e. q_k = 1 / (2 sin θ_k), k = 1..⌊n/2⌋; an odd order adds the real pole s = −1.
std::vector<double> prototype_qs(int order) {
  std::vector<double> qs;
  for (int k = 1; k <= order / 2; ++k) {
    const double theta = (2.0 * k - 1.0) * std::numbers::pi / (2.0 * order);
    qs.push_back(1.0 / (2.0 * std::sin(theta)));
  }
  return qs;
}

enum class Kind { lowpass, highpass };

// Bilinear transform s = (1/K)(1 − z⁻¹)/(1 + z⁻¹) with K = tan(π fc / fs): pre-warping puts the
// analog prototype's ω = 1 exactly at fc, so the −3 dB point of the digital filter is fc.
std::vector<Biquad> digital(Kind kind, int order, double cutoff_hz, double fs) {
  const double k = std::tan(std::numbers::pi * cutoff_hz / fs);
  const double k2 = k * k;
  std::vector<Biquad> sections;
  for (const double q : prototype_qs(order)) {
    // 1/(s² + s/q + 1) (low-pass) or s²/(s² + s/q + 1) (high-pass), both over K² + K/q + 1.
    const double norm = 1.0 / (1.0 + k / q + k2);
    Biquad b;
    if (kind == Kind::lowpass) {
      b.b0 = k2 * norm;
      b.b1 = 2.0 * b.b0;
      b.b2 = b.b0;
    } else {
      b.b0 = norm;
      b.b1 = -2.0 * norm;
      b.b2 = norm;
    }
    b.a1 = 2.0 * (k2 - 1.0) * norm;
    b.a2 = (1.0 - k / q + k2) * norm;
    sections.push_back(b);
  }
  if (order % 2 == 1) {
    // 1/(s + 1) or s/(s + 1): a first-order section held in a biquad with b2 = a2 = 0.
    const double norm = 1.0 / (1.0 + k);
    Biquad b;
    if (kind == Kind::lowpass) {
      b.b0 = k * norm;
      b.b1 = b.b0;
    } else {
      b.b0 = norm;
      b.b1 = -norm;
    }
    b.b2 = 0.0;
    b.a1 = (k - 1.0) * norm;
    b.a2 = 0.0;
    sections.push_back(b);
  }
  return sections;
}

}  // namespace

std::vector<AnalogSection> analog_butterworth_lowpass(int order, double cutoff_hz) {
  check_order("analog_butterworth_lowpass", order);
  if (!std::isfinite(cutoff_hz) || cutoff_hz <= 0.0) {
    fail("analog_butterworth_lowpass", "cutoff_hz must be finite and > 0", cutoff_hz);
  }
  const double omega = 2.0 * std::numbers::pi * cutoff_hz;
  std::vector<AnalogSection> sections;
  for (const double q : prototype_qs(order)) {
    sections.push_back(AnalogSection{omega, q, false});
  }
  if (order % 2 == 1) {
    sections.push_back(AnalogSection{omega, 0.0, true});
  }
  return sections;
}

std::vector<Biquad> butterworth_lowpass(int order, double cutoff_hz, double fs) {
  check_order("butterworth_lowpass", order);
  check_digital("butterworth_lowpass", "cutoff_hz", cutoff_hz, fs);
  return digital(Kind::lowpass, order, cutoff_hz, fs);
}

std::vector<Biquad> butterworth_highpass(int order, double cutoff_hz, double fs) {
  check_order("butterworth_highpass", order);
  check_digital("butterworth_highpass", "cutoff_hz", cutoff_hz, fs);
  return digital(Kind::highpass, order, cutoff_hz, fs);
}

std::vector<Biquad> butterworth_bandpass(int order, double low_hz, double high_hz, double fs) {
  check_order("butterworth_bandpass", order);
  check_digital("butterworth_bandpass", "low_hz", low_hz, fs);
  check_digital("butterworth_bandpass", "high_hz", high_hz, fs);
  if (!(low_hz < high_hz)) {
    fail("butterworth_bandpass", "low_hz must be below high_hz = " + std::to_string(high_hz),
         low_hz);
  }
  std::vector<Biquad> sections = digital(Kind::highpass, order, low_hz, fs);
  const std::vector<Biquad> low = digital(Kind::lowpass, order, high_hz, fs);
  sections.insert(sections.end(), low.begin(), low.end());
  return sections;
}

std::vector<Biquad> butterworth_band(int order, double low_hz, double high_hz, double fs) {
  return low_hz == 0.0 ? butterworth_lowpass(order, high_hz, fs) : butterworth_bandpass(order, low_hz, high_hz, fs);
}

}  // namespace panelbass::dsp

#pragma once
// Butterworth filter design: the analog prototype (for simulated analog filters) and digital
// second-order sections by the bilinear transform with pre-warping.

#include <vector>

#include "dsp/biquad.h"

namespace panelbass::dsp {

/// One section of an analog low-pass: ω²/(s² + (ω/q)s + ω²), or ω/(s + ω) when first_order.
struct AnalogSection {
  double omega = 0.0;        ///< rad/s
  double q = 0.0;            ///< quality factor (unused for a first-order section)
  bool first_order = false;
};

/// The sections of an analog Butterworth low-pass of `order` (1..16) with -3 dB at `cutoff_hz`.
/// Throws std::invalid_argument for an order or cutoff out of range.
std::vector<AnalogSection> analog_butterworth_lowpass(int order, double cutoff_hz);

/// Digital Butterworth low-pass of `order` (1..16), -3 dB at `cutoff_hz` (0 < cutoff < fs/2).
std::vector<Biquad> butterworth_lowpass(int order, double cutoff_hz, double fs);

/// Digital Butterworth high-pass of `order` (1..16), -3 dB at `cutoff_hz` (0 < cutoff < fs/2).
std::vector<Biquad> butterworth_highpass(int order, double cutoff_hz, double fs);

/// Band-pass as a high-pass at `low_hz` cascaded with a low-pass at `high_hz`, each of `order`.
std::vector<Biquad> butterworth_bandpass(int order, double low_hz, double high_hz, double fs);

/// The chain's band-pass: butterworth_bandpass(), or with `low_hz` = 0 the low-pass alone (the thesis's
/// "0–1200 Hz" band).
std::vector<Biquad> butterworth_band(int order, double low_hz, double high_hz, double fs);

}  // namespace panelbass::dsp

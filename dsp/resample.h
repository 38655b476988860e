#pragma once
// Offline sample-rate conversion through libsamplerate (its best band-limited sinc converter): how a
// recording at the sound card's rate reaches a chain that runs at the models' rate, and back.

#include <Eigen/Core>

namespace panelbass::dsp {

/// `signal`, sampled at `from_hz`, resampled to `to_hz` with libsamplerate's SRC_SINC_BEST_QUALITY
/// converter (band-limited to the lower of the two Nyquist frequencies, time-aligned: sample k of the
/// result is at time k/to_hz). The result has round(size · to_hz / from_hz) samples; equal rates return
/// the signal unchanged. libsamplerate computes in single precision (errors about 1e-7 of full scale);
/// a signal that starts or ends abruptly rings for about 20 ms at either end, as through any
/// band-limited converter.
/// Throws std::invalid_argument for a rate that is not finite and > 0, a ratio outside [1/256, 256], a
/// non-finite sample, or a failure that libsamplerate reports (its message included).
Eigen::VectorXd resample(const Eigen::VectorXd& signal, double from_hz, double to_hz);

}  // namespace panelbass::dsp

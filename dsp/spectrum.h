#pragma once
// Spectra by Welch's method (FFT from Eigen's FFT module, kissfft backend).

#include <Eigen/Core>

namespace panelbass::dsp {

/// Segment window.
enum class Window { hann, rectangular };

/// How a Welch estimate is made.
struct WelchSpec {
  std::size_t segment = 1024;   ///< samples per segment (the FFT length)
  double overlap = 0.5;         ///< fraction of a segment shared with the next, in [0, 1)
  Window window = Window::hann;
};

/// A one-sided power spectral density.
struct PowerSpectrum {
  Eigen::VectorXd frequency;  ///< Hz, bins 0..segment/2
  Eigen::VectorXd psd;        ///< units²/Hz; integrates (sum * df) to the signal's mean square
};

/// The Welch segment for a record of `samples`: the longest power of 2 from 64 up to `longest` that the record holds
/// four times over (seven averages at 50 % overlap; a segment not much longer than the impulse response leaks), 64
/// when it holds fewer than four of 128.
std::size_t welch_segment(Eigen::Index samples, std::size_t longest = 1024);

/// The Welch segment a residual's spectrum is read by (its noise level and peaks: the diagnosis, and its figures at
/// either door): the longest power of 2 from 256 up to 2048 that the record holds eight times over (≥ 15 averages
/// at 50 % overlap), 256 when it holds fewer, and welch_segment()'s for a record
/// shorter than 256 samples.
std::size_t residual_welch_segment(Eigen::Index samples);

/// Welch PSD of `x` at sample rate `fs`. Throws std::invalid_argument if x is shorter than a segment.
PowerSpectrum welch_psd(const Eigen::VectorXd& x, double fs, const WelchSpec& spec = {});

/// A frequency response estimate with its coherence.
struct FrequencyResponse {
  Eigen::VectorXd frequency;   ///< Hz, bins 0..segment/2
  Eigen::VectorXcd h;          ///< H1 = S_uy / S_uu
  Eigen::VectorXd coherence;   ///< |S_uy|² / (S_uu S_yy), in [0, 1]
};

/// H1 frequency response from input `u` to output `y` (equal lengths) by Welch averaging.
FrequencyResponse h1_frf(const Eigen::VectorXd& u, const Eigen::VectorXd& y, double fs,
                         const WelchSpec& spec = {});

}  // namespace panelbass::dsp

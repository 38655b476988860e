#include "dsp/spectrum.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/FFT>
#include <vector>

namespace panelbass::dsp {
namespace {

[[noreturn]] void fail(const char* where, const std::string& what, double value) {
  std::ostringstream message;
  message.precision(17);
  message << where << ": " << what << ", got " << value;
  throw std::invalid_argument(message.str());
}

void check_spec(const char* where, double fs, const WelchSpec& spec) {
  if (!std::isfinite(fs) || fs <= 0.0) {
    fail(where, "fs must be finite and > 0", fs);
  }
  if (spec.segment < 2) {
    fail(where, "segment must be >= 2", static_cast<double>(spec.segment));
  }
  if (!(spec.overlap >= 0.0 && spec.overlap < 1.0)) {
    fail(where, "overlap must be in [0, 1)", spec.overlap);
  }
}

void check_length(const char* where, const char* name, Eigen::Index size, std::size_t segment) {
  if (size < static_cast<Eigen::Index>(segment)) {
    fail(where, std::string(name) + " must hold at least one segment of " +
                    std::to_string(segment) + " samples; its length",
         static_cast<double>(size));
  }
}

// The periodic Hann window (w[n] = ½ − ½cos(2πn/N), n = 0..N−1), not the symmetric one: its
// N-point DFT has exactly three non-zero bins, which is what spectral analysis wants.
Eigen::VectorXd make_window(Window window, std::size_t segment) {
  const auto n = static_cast<Eigen::Index>(segment);
  if (window == Window::rectangular) {
    return Eigen::VectorXd::Ones(n);
  }
  Eigen::VectorXd w(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    w[i] = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * static_cast<double>(i) /
                                static_cast<double>(n));
  }
  return w;
}

// Segment starts: hop = segment − round(overlap·segment), at least one sample.
std::vector<Eigen::Index> segment_starts(Eigen::Index length, const WelchSpec& spec) {
  const auto segment = static_cast<Eigen::Index>(spec.segment);
  const auto shared =
      static_cast<Eigen::Index>(std::llround(spec.overlap * static_cast<double>(spec.segment)));
  const Eigen::Index hop = std::max<Eigen::Index>(1, segment - shared);
  std::vector<Eigen::Index> starts;
  for (Eigen::Index s = 0; s + segment <= length; s += hop) {
    starts.push_back(s);
  }
  return starts;
}

// Bins 0..N/2 of the windowed segment x[start .. start+N).
class SegmentTransform {
 public:
  SegmentTransform(Window window, std::size_t segment)
      : window_(make_window(window, segment)), buffer_(segment) {
    fft_.SetFlag(Eigen::FFT<double>::HalfSpectrum);
  }

  const std::vector<std::complex<double>>& operator()(const Eigen::VectorXd& x, Eigen::Index start) {
    for (std::size_t i = 0; i < buffer_.size(); ++i) {
      const auto j = static_cast<Eigen::Index>(i);
      buffer_[i] = x[start + j] * window_[j];
    }
    fft_.fwd(bins_, buffer_);
    return bins_;
  }

  const Eigen::VectorXd& window() const { return window_; }

 private:
  Eigen::VectorXd window_;
  std::vector<double> buffer_;
  std::vector<std::complex<double>> bins_;
  Eigen::FFT<double> fft_;
};

Eigen::VectorXd bin_frequencies(std::size_t segment, double fs) {
  const auto bins = static_cast<Eigen::Index>(segment / 2 + 1);
  Eigen::VectorXd f(bins);
  for (Eigen::Index k = 0; k < bins; ++k) {
    f[k] = static_cast<double>(k) * fs / static_cast<double>(segment);
  }
  return f;
}

}  // namespace

std::size_t welch_segment(Eigen::Index samples, std::size_t longest) {
  const auto limit = std::min<Eigen::Index>(static_cast<Eigen::Index>(longest), samples / 4);
  std::size_t segment = 64;
  while (static_cast<Eigen::Index>(2 * segment) <= limit) segment *= 2;
  return segment;
}

std::size_t residual_welch_segment(Eigen::Index samples) {
  constexpr std::size_t shortest = 256, longest = 2048, times = 8;
  if (samples < static_cast<Eigen::Index>(shortest)) return welch_segment(samples);
  std::size_t segment = shortest;
  while (2 * segment * times <= static_cast<std::size_t>(samples) && segment < longest) segment *= 2;
  return segment;
}

PowerSpectrum welch_psd(const Eigen::VectorXd& x, double fs, const WelchSpec& spec) {
  constexpr const char* where = "welch_psd";
  check_spec(where, fs, spec);
  check_length(where, "x", x.size(), spec.segment);

  SegmentTransform transform(spec.window, spec.segment);
  const std::vector<Eigen::Index> starts = segment_starts(x.size(), spec);
  const auto bins = static_cast<Eigen::Index>(spec.segment / 2 + 1);
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(bins);
  for (const Eigen::Index start : starts) {
    const auto& spectrum = transform(x, start);
    for (Eigen::Index k = 0; k < bins; ++k) {
      sum[k] += std::norm(spectrum[static_cast<std::size_t>(k)]);
    }
  }

  // Density scaling: P[k] = 2 |X_k|² / (fs · Σw²) (one-sided, so every bin but DC and an even
  // length's Nyquist counts twice). By Parseval, Σ P[k]·fs/N then equals Σ(x·w)²/Σw², the mean
  // square of x when the window is uncorrelated with the signal's power.
  const double window_power = transform.window().squaredNorm();
  PowerSpectrum result;
  result.frequency = bin_frequencies(spec.segment, fs);
  result.psd = sum / (static_cast<double>(starts.size()) * fs * window_power);
  const Eigen::Index last = (spec.segment % 2 == 0) ? bins - 1 : bins;
  result.psd.segment(1, last - 1) *= 2.0;
  return result;
}

FrequencyResponse h1_frf(const Eigen::VectorXd& u, const Eigen::VectorXd& y, double fs,
                         const WelchSpec& spec) {
  constexpr const char* where = "h1_frf";
  check_spec(where, fs, spec);
  if (u.size() != y.size()) {
    fail(where, "u and y must have equal lengths (u has " + std::to_string(u.size()) +
                    "); y's length",
         static_cast<double>(y.size()));
  }
  check_length(where, "u", u.size(), spec.segment);

  SegmentTransform transform_u(spec.window, spec.segment);
  SegmentTransform transform_y(spec.window, spec.segment);
  const auto bins = static_cast<Eigen::Index>(spec.segment / 2 + 1);
  Eigen::VectorXcd s_uy = Eigen::VectorXcd::Zero(bins);
  Eigen::VectorXd s_uu = Eigen::VectorXd::Zero(bins);
  Eigen::VectorXd s_yy = Eigen::VectorXd::Zero(bins);
  // Averaged cross and auto spectra; the common scale factors cancel in H1 and the coherence.
  for (const Eigen::Index start : segment_starts(u.size(), spec)) {
    const auto& uk = transform_u(u, start);
    const auto& yk = transform_y(y, start);
    for (Eigen::Index k = 0; k < bins; ++k) {
      const auto i = static_cast<std::size_t>(k);
      s_uy[k] += std::conj(uk[i]) * yk[i];
      s_uu[k] += std::norm(uk[i]);
      s_yy[k] += std::norm(yk[i]);
    }
  }

  FrequencyResponse result;
  result.frequency = bin_frequencies(spec.segment, fs);
  result.h.resize(bins);
  result.coherence.resize(bins);
  for (Eigen::Index k = 0; k < bins; ++k) {
    // A bin the input never excites has no estimate; 0 (not NaN) keeps the result serialisable.
    result.h[k] = s_uu[k] > 0.0 ? s_uy[k] / s_uu[k] : std::complex<double>(0.0, 0.0);
    const double denominator = s_uu[k] * s_yy[k];
    result.coherence[k] =
        denominator > 0.0 ? std::min(1.0, std::norm(s_uy[k]) / denominator) : 0.0;
  }
  return result;
}

}  // namespace panelbass::dsp

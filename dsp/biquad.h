#pragma once
// Digital second-order sections and their cascade.

#include <Eigen/Core>
#include <complex>
#include <span>
#include <vector>

namespace panelbass::dsp {

/// One digital biquad: H(z) = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2).
struct Biquad {
  double b0 = 1.0, b1 = 0.0, b2 = 0.0;
  double a1 = 0.0, a2 = 0.0;

  /// H(e^{jω}) at `frequency` Hz for sample rate `fs`.
  std::complex<double> response(double frequency, double fs) const;
};

/// A cascade of biquads (second-order sections) with its own state, run in transposed direct form II.
/// Sizing happens in the constructor; process() never allocates.
class SosFilter {
 public:
  /// A cascade of `sections`, state cleared.
  explicit SosFilter(std::vector<Biquad> sections = {});

  /// Filters one sample (inline: the engine's band-pass calls it once per sample).
  double process(double x) noexcept {
    // Transposed direct form II, per section:
    //   y = b0·x + s1;  s1 = b1·x − a1·y + s2;  s2 = b2·x − a2·y
    // (two state values per section, and better rounding behaviour than direct form I/II for
    // low cutoffs because the feedback sums never hold large cancelling terms).
    double v = x;
    const std::size_t n = sections_.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Biquad& s = sections_[i];
      const double y = s.b0 * v + s1_[i];
      s1_[i] = s.b1 * v - s.a1 * y + s2_[i];
      s2_[i] = s.b2 * v - s.a2 * y;
      v = y;
    }
    return v;
  }

  /// out[k] = process(in[k]) over a block (`out` as long as `in`, or `in` itself): the same arithmetic in the
  /// same order, so the same numbers, with the state held in registers over the block (up to 4 sections).
  void process_block(std::span<const double> in, std::span<double> out) noexcept;

  /// Filters a whole signal from the current state (the state carries over to the next call).
  Eigen::VectorXd process(const Eigen::VectorXd& x);

  /// Clears the state.
  void reset() noexcept;

  /// Product of the sections' responses at `frequency` Hz.
  std::complex<double> response(double frequency, double fs) const;

  /// The sections.
  const std::vector<Biquad>& sections() const { return sections_; }

 private:
  std::vector<Biquad> sections_;
  std::vector<double> s1_, s2_;
};

}  // namespace panelbass::dsp

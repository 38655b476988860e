#pragma once
// Digital second-order sections and their cascade.

#include <Eigen/Core>
#include <complex>
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

  /// Filters one sample.
  double process(double x) noexcept;

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

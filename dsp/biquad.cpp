#include "dsp/biquad.h"

#include <cmath>
#include <numbers>

namespace panelbass::dsp {

std::complex<double> Biquad::response(double frequency, double fs) const {
  const double omega = 2.0 * std::numbers::pi * frequency / fs;
  const std::complex<double> z1 = std::polar(1.0, -omega);  // z^-1 on the unit circle
  const std::complex<double> z2 = z1 * z1;
  return (b0 + b1 * z1 + b2 * z2) / (1.0 + a1 * z1 + a2 * z2);
}

SosFilter::SosFilter(std::vector<Biquad> sections)
    : sections_(std::move(sections)), s1_(sections_.size(), 0.0), s2_(sections_.size(), 0.0) {}

double SosFilter::process(double x) noexcept {
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

Eigen::VectorXd SosFilter::process(const Eigen::VectorXd& x) {
  Eigen::VectorXd y(x.size());
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    y[i] = process(x[i]);
  }
  return y;
}

void SosFilter::reset() noexcept {
  for (std::size_t i = 0; i < sections_.size(); ++i) {
    s1_[i] = 0.0;
    s2_[i] = 0.0;
  }
}

std::complex<double> SosFilter::response(double frequency, double fs) const {
  std::complex<double> h(1.0, 0.0);
  for (const Biquad& s : sections_) {
    h *= s.response(frequency, fs);
  }
  return h;
}

}  // namespace panelbass::dsp

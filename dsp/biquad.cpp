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

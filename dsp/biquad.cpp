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

namespace {

// process_block for exactly N sections: coefficients and state in locals, sample by sample through the
// cascade as SosFilter::process runs it (the same expressions, so the same roundings).
template <std::size_t N>
void process_fixed(const std::vector<Biquad>& sections, std::vector<double>& s1, std::vector<double>& s2,
                   std::span<const double> in, std::span<double> out) noexcept {
  Biquad c[N];
  double z1[N], z2[N];
  for (std::size_t i = 0; i < N; ++i) {
    c[i] = sections[i];
    z1[i] = s1[i];
    z2[i] = s2[i];
  }
  for (std::size_t k = 0; k < in.size(); ++k) {
    double v = in[k];
    for (std::size_t i = 0; i < N; ++i) {
      // y = b0·x + s1;  s1 = b1·x − a1·y + s2;  s2 = b2·x − a2·y
      const double y = c[i].b0 * v + z1[i];
      z1[i] = c[i].b1 * v - c[i].a1 * y + z2[i];
      z2[i] = c[i].b2 * v - c[i].a2 * y;
      v = y;
    }
    out[k] = v;
  }
  for (std::size_t i = 0; i < N; ++i) {
    s1[i] = z1[i];
    s2[i] = z2[i];
  }
}

}  // namespace

void SosFilter::process_block(std::span<const double> in, std::span<double> out) noexcept {
  switch (sections_.size()) {
    case 1:
      return process_fixed<1>(sections_, s1_, s2_, in, out);
    case 2:
      return process_fixed<2>(sections_, s1_, s2_, in, out);
    case 3:
      return process_fixed<3>(sections_, s1_, s2_, in, out);
    case 4:
      return process_fixed<4>(sections_, s1_, s2_, in, out);
    default:
      for (std::size_t k = 0; k < in.size(); ++k) out[k] = process(in[k]);
  }
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

#include "models/linear/transfer_function.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace panelbass::models {

Eigen::VectorXcd polynomial_roots(const Eigen::VectorXd& c) {
  if (c.size() == 0 || c[0] == 0.0) throw std::invalid_argument("polynomial roots: leading coefficient is zero");
  const Eigen::Index n = c.size() - 1;
  if (n == 0) return Eigen::VectorXcd(0);
  // Companion matrix of the monic polynomial z^n + (c_1/c_0) z^(n−1) + … + c_n/c_0.
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(n, n);
  companion.row(0) = -c.tail(n).transpose() / c[0];
  companion.diagonal(-1).setOnes();
  return Eigen::EigenSolver<Eigen::MatrixXd>(companion, false).eigenvalues();
}

PoleMode pole_mode(std::complex<double> pole, double fs) {
  const std::complex<double> s = std::log(pole) * fs;
  const double magnitude = std::abs(s);
  return {magnitude / (2.0 * std::numbers::pi), std::abs(s.imag()) / (2.0 * std::numbers::pi),
          magnitude > 0.0 ? -s.real() / magnitude : 1.0};
}

Eigen::VectorXd polynomial_from_roots(const Eigen::VectorXcd& roots) {
  Eigen::VectorXcd p = Eigen::VectorXcd::Zero(roots.size() + 1);
  p[0] = 1.0;
  for (Eigen::Index k = 0; k < roots.size(); ++k) {
    // multiply by (z − r_k)
    for (Eigen::Index j = k + 1; j >= 1; --j) p[j] -= roots[k] * p[j - 1];
  }
  return p.real();
}

Eigen::VectorXcd TransferFunction::poles() const {
  Eigen::VectorXd c(a.size() + 1);
  c << 1.0, a;
  return polynomial_roots(c);
}

Eigen::VectorXcd TransferFunction::zeros() const {
  Eigen::Index first = 0;
  while (first < b.size() && b[first] == 0.0) ++first;
  if (b.size() - first <= 1) return Eigen::VectorXcd(0);
  return polynomial_roots(b.tail(b.size() - first));
}

bool TransferFunction::is_stable(double margin) const {
  if (!all_finite()) return false;
  const Eigen::VectorXcd p = poles();
  for (Eigen::Index k = 0; k < p.size(); ++k) {
    if (!(std::abs(p[k]) < 1.0 - margin)) return false;
  }
  return true;
}

std::complex<double> TransferFunction::response(double frequency, double fs) const {
  const std::complex<double> z_inv = std::polar(1.0, -2.0 * std::numbers::pi * frequency / fs);
  // B(z⁻¹) and A(z⁻¹) by Horner's rule in z⁻¹.
  std::complex<double> num = 0.0, den = 0.0;
  for (Eigen::Index j = b.size() - 1; j >= 0; --j) num = num * z_inv + b[j];
  for (Eigen::Index i = a.size() - 1; i >= 0; --i) den = den * z_inv + a[i];
  den = den * z_inv + 1.0;
  return num * std::pow(z_inv, nk) / den;
}

}  // namespace panelbass::models

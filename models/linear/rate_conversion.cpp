#include "models/linear/rate_conversion.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <map>
#include <stdexcept>
#include <string>

#include "models/io/number_text.h"

namespace panelbass::models {
namespace {

using Complex = std::complex<double>;

/// Poles closer than this (relative to their size) count as repeated: their residues would carry
/// rounding errors amplified by 1/|λ_i − λ_j| and cancel each other in the sum.
constexpr double kRepeatedPoleTolerance = 1e-7;

/// An imaginary part this small (relative to |λ|) is rounding: the pole is real.
constexpr double kRealPoleTolerance = 1e-12;

/// Coefficients p_0..p_n of Π_i (1 − r_i x), x = z⁻¹ (complex; p_0 = 1).
Eigen::VectorXcd product_in_x(const Eigen::VectorXcd& roots) {
  Eigen::VectorXcd p = Eigen::VectorXcd::Zero(roots.size() + 1);
  p[0] = 1.0;
  for (Eigen::Index k = 0; k < roots.size(); ++k) {
    for (Eigen::Index j = k + 1; j >= 1; --j) p[j] -= roots[k] * p[j - 1];
  }
  return p;
}

}  // namespace

TransferFunction convert_rate(const TransferFunction& tf, double fs_from, double fs_to) {
  if (!(fs_from > 0.0) || !(fs_to > 0.0) || !std::isfinite(fs_from) || !std::isfinite(fs_to)) {
    throw std::invalid_argument("convert rate: sample rates must be positive and finite");
  }
  if (!tf.all_finite()) throw std::invalid_argument("convert rate: the model has non-finite coefficients");
  if (tf.nk < 0) throw std::invalid_argument("convert rate: negative input delay");
  const double rho = fs_from / fs_to;     // T_new / T_old
  const double stretch = fs_to / fs_from;  // samples at the new rate per sample at the old

  // Work in x = z⁻¹: H = x^nk·b(x)/a(x), a(x) = 1 + a_1 x + … (trailing zero coefficients are poles at the
  // origin, i.e. no pole in x, and are dropped).
  Eigen::Index na = tf.a.size();
  while (na > 0 && tf.a[na - 1] == 0.0) --na;
  Eigen::VectorXd a(na + 1);
  a << 1.0, tf.a.head(na);
  Eigen::VectorXd b = tf.b;
  if (b.size() == 0) b = Eigen::VectorXd::Zero(1);

  // Polynomial division b(x) = Q(x)·a(x) + R(x), deg R < na: H = x^nk·(Q(x) + R(x)/a(x)).
  Eigen::VectorXd remainder = b;
  Eigen::VectorXd quotient = Eigen::VectorXd::Zero(std::max<Eigen::Index>(b.size() - na, 0));
  for (Eigen::Index k = b.size() - 1; k >= na; --k) {
    const double q = remainder[k] / a[na];
    quotient[k - na] = q;
    remainder.segment(k - na, na + 1) -= q * a;
  }

  // The poles λ_i (roots of z^na·a(1/z)), checked for a continuous-time equivalent.
  Eigen::VectorXcd lambda = Eigen::VectorXcd(0);
  if (na > 0) {
    TransferFunction den;
    den.a = tf.a.head(na);
    lambda = den.poles();
  }
  for (Eigen::Index i = 0; i < na; ++i) {
    if (std::abs(lambda[i].imag()) <= kRealPoleTolerance * std::abs(lambda[i])) lambda[i].imag(0.0);
    if (lambda[i].imag() == 0.0 && lambda[i].real() < 0.0) {
      throw std::invalid_argument("convert rate: pole " + number_text(lambda[i]) +
                                  " lies on the negative real axis (no continuous-time equivalent)");
    }
    for (Eigen::Index j = 0; j < i; ++j) {
      if (std::abs(lambda[i] - lambda[j]) <= kRepeatedPoleTolerance * std::max(1.0, std::abs(lambda[i]))) {
        throw std::invalid_argument("convert rate: repeated pole " + number_text(lambda[i]) +
                                    " (partial fractions need distinct poles)");
      }
    }
  }

  // Residues of R(x)/a(x) = Σ r_i/(1 − λ_i x):
  //   r_i = R(1/λ_i) / Π_{j≠i} (1 − λ_j/λ_i).
  Eigen::VectorXcd residue(na);
  for (Eigen::Index i = 0; i < na; ++i) {
    const Complex x = 1.0 / lambda[i];
    Complex num = 0.0;
    for (Eigen::Index k = na - 1; k >= 0; --k) num = num * x + remainder[k];
    Complex den = 1.0;
    for (Eigen::Index j = 0; j < na; ++j) {
      if (j != i) den *= 1.0 - lambda[j] / lambda[i];
    }
    residue[i] = num / den;
  }

  // Appendix 2: each mode keeps its continuous decay and frequency, s_i = ln(λ_i)/T_old, so
  //   μ_i = exp(s_i·T_new) = λ_i^(T_new/T_old)   (principal power: conjugate pairs stay pairs),
  // and impulse invariance (h[k] = T·h_c(kT)) scales the residue with the sample interval:
  //   r_i' = r_i·T_new/T_old.
  Eigen::VectorXcd mu(na), residue_new(na);
  for (Eigen::Index i = 0; i < na; ++i) {
    mu[i] = std::exp(rho * std::log(lambda[i]));
    if (lambda[i].imag() == 0.0) mu[i].imag(0.0);
    residue_new[i] = residue[i] * rho;
  }

  // Delays are kept in seconds: the modal part starts at round(nk·fs_to/fs_from) samples, and each
  // quotient term q_j (a delayed direct feed-through, kept with its weight) moves to
  // round((nk + j)·fs_to/fs_from). When the delay is not a whole number of new samples it is rounded to
  // the nearest one (half away from zero); terms that land on the same sample add.
  const auto to_new = [&](Eigen::Index samples) {
    return static_cast<Eigen::Index>(std::llround(static_cast<double>(samples) * stretch));
  };
  Eigen::Index nk_new = to_new(tf.nk);
  std::map<Eigen::Index, double> direct;  // new-rate delay → weight
  for (Eigen::Index j = 0; j < quotient.size(); ++j) {
    if (quotient[j] != 0.0) direct[to_new(tf.nk + j)] += quotient[j];
  }
  if (na == 0 && !direct.empty()) nk_new = direct.begin()->first;
  Eigen::Index fir_len = 0;  // taps of Q'(x) counted from nk_new
  for (const auto& [delay, weight] : direct) fir_len = std::max(fir_len, delay - nk_new + 1);
  Eigen::VectorXd quotient_new = Eigen::VectorXd::Zero(fir_len);
  for (const auto& [delay, weight] : direct) quotient_new[delay - nk_new] += weight;

  // Recombined over the common denominator a'(x) = Π (1 − μ_i x):
  //   b'(x) = Q'(x)·a'(x) + Σ_i r_i'·Π_{j≠i} (1 − μ_j x).
  const Eigen::VectorXcd a_new = product_in_x(mu);
  const Eigen::Index nb_new = std::max<Eigen::Index>(na > 0 ? na : 1, fir_len + na);
  Eigen::VectorXcd b_new = Eigen::VectorXcd::Zero(nb_new);
  for (Eigen::Index j = 0; j < fir_len; ++j) b_new.segment(j, na + 1) += quotient_new[j] * a_new;
  for (Eigen::Index i = 0; i < na; ++i) {
    Eigen::VectorXcd others(na - 1);
    for (Eigen::Index j = 0, k = 0; j < na; ++j) {
      if (j != i) others[k++] = mu[j];
    }
    b_new.head(na) += residue_new[i] * product_in_x(others);
  }

  TransferFunction out;
  out.a = a_new.tail(na).real();
  out.b = b_new.real();
  out.nk = static_cast<int>(nk_new);
  return out;
}

}  // namespace panelbass::models

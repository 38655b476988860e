// The FIR → Hankel-SVD → output-error method (thesis ch. 4, fig. 4.1, Backx).
#include "models/linear/backx_estimator.h"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/decimate.h"
#include "models/linear/estimation_error.h"
#include "models/linear/fir_estimator.h"
#include "models/linear/hankel_reduction.h"
#include "models/linear/impulse_estimate.h"
#include "models/linear/rate_conversion.h"

namespace panelbass::models {
namespace {

std::string backx_name(const ModelOrders& o) {
  return "Backx(" + std::to_string(o.na) + "," + std::to_string(o.nb) + "," + std::to_string(o.nk) + ")";
}

/// FIR length from the correlation's impulse-length estimate: 1.5 × the length, at least 3·na and
/// 2·na + 2 (what the Hankel step needs), at most N/10. The lag window doubles until the response has
/// ended inside its first half (estimate_impulse measures the noise on the second half); it never needs
/// to exceed about 2·N/15, beyond which the N/10 cap decides anyway.
Eigen::Index default_taps(const Eigen::VectorXd& u, const Eigen::VectorXd& y, int na, const std::string& name) {
  const Eigen::Index N = u.size();
  const Eigen::Index cap = std::min<Eigen::Index>(N / 2 - 1, 2 * N / 15 + 40);
  if (cap < 40) {
    throw EstimationError(name + ": " + std::to_string(N) +
                          " samples (at the working rate) are too few to estimate the impulse length");
  }
  Eigen::Index max_lag = std::min<Eigen::Index>(cap, 256);
  ImpulseEstimate e;
  for (;;) {
    e = estimate_impulse(u, y, max_lag);
    if (e.length + 20 < max_lag / 2 || max_lag >= cap) break;
    max_lag = std::min<Eigen::Index>(cap, 2 * max_lag);
  }
  Eigen::Index taps = static_cast<Eigen::Index>(std::ceil(1.5 * e.length));
  taps = std::max<Eigen::Index>({taps, 3 * static_cast<Eigen::Index>(na), 2 * static_cast<Eigen::Index>(na) + 2});
  return std::min<Eigen::Index>(taps, N / 10);
}

/// `tf` without its modes on the negative real axis. Such a pole oscillates at exactly the working
/// rate's Nyquist frequency, above the anti-alias cutoff, where the decimated data hold only the filter's
/// stop band and noise; it has no continuous-time equivalent to carry to fs (mapping its decay alone
/// would put a slow real pole, an almost-integrator, into the band). Each is removed from the partial
/// fractions: with H = b(x)/((1 − λx)·a_rest(x)), x = z⁻¹, its residue is r = b(1/λ)/a_rest(1/λ), and
///   H − r/(1 − λx) = (b(x) − r·a_rest(x)) / ((1 − λx)·a_rest(x)),
/// whose numerator vanishes at x = 1/λ and is divided by (1 − λx) exactly.
TransferFunction without_negative_real_modes(const TransferFunction& tf) {
  TransferFunction out = tf;
  for (;;) {
    const Eigen::VectorXcd p = out.poles();
    Eigen::Index found = -1;
    for (Eigen::Index i = 0; i < p.size() && found < 0; ++i) {
      if (std::abs(p[i].imag()) <= 1e-12 * std::abs(p[i]) && p[i].real() < 0.0) found = i;
    }
    if (found < 0) return out;
    const double lambda = p[found].real();
    Eigen::VectorXcd rest(p.size() - 1);
    for (Eigen::Index i = 0, k = 0; i < p.size(); ++i) {
      if (i != found) rest[k++] = p[i];
    }
    const Eigen::VectorXd a_rest = polynomial_from_roots(rest);  // [1, …] = coefficients of a_rest(x)
    const auto eval = [](const Eigen::VectorXd& c, double x) {
      double v = 0.0;
      for (Eigen::Index k = c.size() - 1; k >= 0; --k) v = v * x + c[k];
      return v;
    };
    const double residue = eval(out.b, 1.0 / lambda) / eval(a_rest, 1.0 / lambda);
    Eigen::VectorXd c = Eigen::VectorXd::Zero(std::max(out.b.size(), a_rest.size()));
    c.head(out.b.size()) += out.b;
    c.head(a_rest.size()) -= residue * a_rest;
    // c(x) = (1 − λx)·d(x):  d_0 = c_0,  d_k = c_k + λ·d_(k−1).
    Eigen::VectorXd d(std::max<Eigen::Index>(c.size() - 1, 1));
    d[0] = c[0];
    for (Eigen::Index k = 1; k < d.size(); ++k) d[k] = c[k] + lambda * d[k - 1];
    out.a = a_rest.tail(a_rest.size() - 1);
    out.b = d;
  }
}

/// `tf` with its denominator padded to `na` coefficients by poles at the origin (a model that removed
/// modes, or whose poles at the origin were dropped, keeps the order asked for; output error can move them).
TransferFunction with_poles(const TransferFunction& tf, int na) {
  if (tf.na() >= na) return tf;
  Eigen::VectorXd a(na);
  a << tf.a, Eigen::VectorXd::Zero(na - tf.na());
  TransferFunction out;
  out.a = a;
  out.b = tf.b;
  out.nk = tf.nk;
  return out;
}

/// The numerator with `nb` coefficients at delay `nk` that, over the fixed denominator A of `poles`,
/// best explains the data: the output-error optimum given the poles, a linear least-squares problem
///   min_b Σ_k (y(k) − Σ_j b_j·v(k − nk − j))²,  v = u/A(q).
/// Fitting the data rather than the truncated FIR keeps the low-frequency gain the FIR cannot hold.
TransferFunction numerator_for_poles(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const TransferFunction& poles,
                                     int nb, int nk) {
  const Eigen::Index n = u.size();
  // v(k) = u(k) − Σ_i a_i·v(k − i)
  Eigen::VectorXd v(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    double s = u[k];
    for (Eigen::Index i = 1; i <= poles.a.size() && i <= k; ++i) s -= poles.a[i - 1] * v[k - i];
    v[k] = s;
  }
  Eigen::MatrixXd V = Eigen::MatrixXd::Zero(n, nb);
  for (Eigen::Index j = 0; j < nb; ++j) {
    const Eigen::Index shift = nk + j;
    if (shift < n) V.col(j).tail(n - shift) = v.head(n - shift);
  }
  TransferFunction out;
  out.a = poles.a;
  out.b = V.colPivHouseholderQr().solve(y);
  out.nk = nk;
  return out;
}

}  // namespace

BackxResult estimate_backx(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const ModelOrders& orders,
                           double fs, const BackxOptions& options) {
  const std::string name = backx_name(orders);
  if (u.size() != y.size()) {
    throw EstimationError(name + ": input and output lengths differ (" + std::to_string(u.size()) + " and " +
                          std::to_string(y.size()) + ")");
  }
  if (!u.allFinite() || !y.allFinite()) throw EstimationError(name + ": the data are not finite");
  if (orders.na < 1 || orders.nb < 1 || orders.nk < 0) {
    throw EstimationError(name + ": orders must have na >= 1, nb >= 1, nk >= 0");
  }
  if (!(fs > 0.0) || !std::isfinite(fs)) throw EstimationError(name + ": the sample rate must be positive");
  if (options.decimation < 1) {
    throw EstimationError(name + ": decimation must be >= 1, got " + std::to_string(options.decimation));
  }
  if (options.fir_taps < 0) throw EstimationError(name + ": fir_taps must be >= 0");
  const int factor = options.decimation;
  const double fs_work = fs / factor;

  BackxResult result;
  TransferFunction working;
  Eigen::Index taps = 0;
  try {
    // Behind the anti-alias filter and at fs/factor the impulse response is factor times shorter, and
    // so is the FIR (the thesis: 3000 → 1000 Hz shortened it to 60 samples).
    const Eigen::VectorXd ud = dsp::decimate(u, factor);
    const Eigen::VectorXd yd = dsp::decimate(y, factor);
    taps = options.fir_taps > 0 ? options.fir_taps : default_taps(ud, yd, orders.na, name);
    result.fir = estimate_fir(ud, yd, taps);
    const StateSpace reduced = hankel_reduction(result.fir, orders.na, &result.hankel_singular_values);
    working = to_transfer_function(reduced);
  } catch (const std::invalid_argument& e) {
    throw EstimationError(name + ": " + e.what());
  }

  // Back at fs (appendix 2: each mode keeps its continuous decay and frequency).
  TransferFunction at_fs = working;
  if (factor > 1) {
    try {
      at_fs = convert_rate(without_negative_real_modes(working), fs_work, fs);
    } catch (const std::invalid_argument& e) {
      throw EstimationError(name + ": the reduced model cannot be carried back to " + std::to_string(fs) +
                            " Hz: " + e.what());
    }
  }
  at_fs = stabilized(with_poles(at_fs, orders.na));

  // The requested numerator orders at fs: with the Hankel poles fixed, nb coefficients at delay nk are
  // fitted to the data by least squares (the reduced model's own numerator is Hankel's D + na
  // coefficients at nk = 0, and carries the truncated FIR's errors).
  result.reduced = numerator_for_poles(u, y, at_fs, orders.nb, orders.nk);
  if (!result.reduced.all_finite()) throw EstimationError(name + ": the reduced model is not finite");

  result.oe = estimate_oe(u, y, result.reduced, options.oe);
  result.tf = result.oe.tf;
  return result;
}

}  // namespace panelbass::models

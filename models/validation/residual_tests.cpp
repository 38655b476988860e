#include "models/validation/residual_tests.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "dsp/correlation.h"

namespace panelbass::models {
namespace {

// Chance of a false alarm from each of a test's two criteria on a white, independent residual.
constexpr double kFalseAlarm = 0.001;
// The two-sided 95 % band of Billings & Voon's plots.
constexpr double kBandConfidence = 0.95;

[[noreturn]] void fail(const std::string& what) { throw std::invalid_argument("residual tests: " + what); }

// x − mean(x), refusing a constant signal (its correlation is undefined).
Eigen::VectorXd centred(const Eigen::VectorXd& x, const char* name) {
  Eigen::VectorXd c = x.array() - x.mean();
  if (!(c.squaredNorm() > 0.0)) fail(std::string(name) + " is constant");
  return c;
}

// φ_ab(τ) = Σ_t a(t−τ)·b(t) / √(Σ a² · Σ b²) for centred a, b; τ may be negative.
double correlation(const Eigen::VectorXd& a, const Eigen::VectorXd& b, int tau, double scale) {
  const Eigen::Index n = a.size();
  const Eigen::Index t = std::abs(tau);
  return tau >= 0 ? a.head(n - t).dot(b.tail(n - t)) / scale : a.tail(n - t).dot(b.head(n - t)) / scale;
}

// Smallest c with P(Binomial(n, p) ≤ c) ≥ 1 − alpha.
int binomial_quantile(int n, double p, double alpha) {
  double pmf = std::pow(1.0 - p, n);  // P(X = 0)
  double cdf = pmf;
  int c = 0;
  while (cdf < 1.0 - alpha && c < n) {
    // P(X = c+1) = P(X = c)·(n − c)/(c + 1)·p/(1 − p)
    pmf *= static_cast<double>(n - c) / static_cast<double>(c + 1) * p / (1.0 - p);
    cdf += pmf;
    ++c;
  }
  return c;
}

// φ_ab over lags first..last, shifted by `offset` (φ_ε(εu)(τ) is φ at lag τ + 1), and its verdict.
CorrelationTest run_test(const char* name, const Eigen::VectorXd& a, const Eigen::VectorXd& b, int first, int last,
                         int offset) {
  CorrelationTest test;
  test.name = name;
  const Eigen::Index n = a.size();
  const double scale = std::sqrt(a.squaredNorm() * b.squaredNorm());
  const int count = last - first + 1;
  test.values.resize(count);
  for (int tau = first; tau <= last; ++tau) {
    test.lags.push_back(tau);
    test.values[tau - first] = correlation(a, b, tau + offset, scale);
  }
  test.band = dsp::correlation_noise_band(n, kBandConfidence);
  test.peak_band = dsp::correlation_noise_band(n, 1.0 - kFalseAlarm / count);
  test.outside = static_cast<int>((test.values.array().abs() > test.band).count());
  test.fraction_outside = static_cast<double>(test.outside) / count;
  test.allowed_outside = binomial_quantile(count, 1.0 - kBandConfidence, kFalseAlarm);
  test.peak = test.values.cwiseAbs().maxCoeff();
  test.passes = test.outside <= test.allowed_outside && test.peak <= test.peak_band;
  return test;
}

}  // namespace

ResidualTests residual_tests(const Eigen::VectorXd& u, const Eigen::VectorXd& residual, int max_lag) {
  const Eigen::Index n = u.size();
  if (residual.size() != n) {
    fail("u has " + std::to_string(n) + " samples, the residual " + std::to_string(residual.size()));
  }
  if (max_lag < 1) fail("max lag must be >= 1, got " + std::to_string(max_lag));
  if (n < 4 * (static_cast<Eigen::Index>(max_lag) + 1)) {
    fail(std::to_string(n) + " samples are too few for max lag " + std::to_string(max_lag) + " (need " +
         std::to_string(4 * (max_lag + 1)) + ")");
  }
  if (!u.allFinite()) fail("u has a non-finite sample");
  if (!residual.allFinite()) fail("the residual has a non-finite sample");

  // Mean-removed signals: u, ε, u²' = u² − mean(u²), ε²' and the product εu (B&V 1986).
  const Eigen::VectorXd uc = centred(u, "u");
  const Eigen::VectorXd e = centred(residual, "the residual");
  const Eigen::VectorXd u2 = centred(u.array().square(), "u²");
  const Eigen::VectorXd e2 = centred(residual.array().square(), "the residual²");
  const Eigen::VectorXd eu = centred(residual.cwiseProduct(u), "the residual·u");

  ResidualTests r;
  r.ee = run_test("phi_ee", e, e, 1, max_lag, 0);
  r.ue = run_test("phi_ue", uc, e, -max_lag, max_lag, 0);
  r.u2e = run_test("phi_u2e", u2, e, -max_lag, max_lag, 0);
  r.u2e2 = run_test("phi_u2e2", u2, e2, -max_lag, max_lag, 0);
  // φ_ε(εu)(τ) = E[ε(t)·(εu)(t−1−τ)]: the correlation of εu leading ε by τ + 1
  r.e_eu = run_test("phi_e_eu", eu, e, 0, max_lag, 1);

  r.input_tests_pass = r.ue.passes && r.u2e.passes && r.u2e2.passes && r.e_eu.passes;
  r.passes = r.input_tests_pass && r.ee.passes;

  // What each failure points to (Billings & Voon's table), most specific to the input first.
  const std::pair<const CorrelationTest*, const char*> meanings[] = {
      {&r.ue, "the residual correlates with u → unmodelled linear dynamics (order, delay or a missing mode)"},
      {&r.u2e, "the residual correlates with u² → unmodelled even-order nonlinearity"},
      {&r.u2e2, "the residual's power correlates with u² → unmodelled odd-order nonlinearity (or input-dependent noise)"},
      {&r.e_eu, "the residual correlates with past residual × input → unmodelled nonlinear noise or output–input cross terms"},
      {&r.ee, "the residual is coloured → coloured noise, or model error the input tests miss (a simulation residual "
              "well above the noise floor is model error)"},
  };
  for (const auto& [test, meaning] : meanings) {
    if (!test->passes) r.explanation += (r.explanation.empty() ? "" : "; ") + std::string(meaning);
  }
  if (r.explanation.empty()) {
    r.explanation = "no correlation beyond chance → the residual is consistent with white noise independent of u";
  }
  return r;
}

}  // namespace panelbass::models

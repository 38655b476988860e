#pragma once
// Correlation tests of a model's residual (Billings & Voon, "Correlation based model validity tests for
// non-linear models", Int. J. Control 44(1), 1986): a model that explains everything the input can
// explain leaves a residual ε that is white and uncorrelated with u, u²' and the products below. The
// higher-order tests find what the linear ones (φ_εε, φ_uε) cannot: an unmodelled nonlinearity.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace panelbass::models {

/// One correlation function over its lags, with its 95 % band and verdict.
struct CorrelationTest {
  std::string name;            ///< "phi_ee", "phi_ue", "phi_u2e", "phi_u2e2" or "phi_e_eu"
  std::vector<int> lags;       ///< τ of each value
  Eigen::VectorXd values;      ///< the normalised correlation at each lag, in [−1, 1]
  double band = 0.0;           ///< 1.96/√N: the 95 % band of a correlation of independent white signals
  int outside = 0;             ///< lags with |φ| > band
  double fraction_outside = 0.0;   ///< outside / number of lags
  /// The most lags that chance alone puts outside the band: the 99.9 % quantile of Binomial(lags, 0.05)
  /// (for 21 or 41 lags: 5 or 7, so the "5 % of lags" rule with room for chance).
  int allowed_outside = 0;
  /// Band that any lag of a white residual exceeds with probability 0.1 % over all lags together
  /// (Bonferroni: z = Φ⁻¹(1 − 0.0005/lags), band z/√N; about 4.1/√N for 41 lags).
  double peak_band = 0.0;
  double peak = 0.0;           ///< max |φ| over the lags
  /// Passes when outside ≤ allowed_outside and peak ≤ peak_band: a white independent residual fails
  /// each test with probability about 0.2 % (all five together: 0.75 % over 2000 seeds), while one
  /// strong correlation at a single lag still fails. A coloured residual makes neighbouring lags move
  /// together, so the count criterion trips by chance more often (an AR(1) residual with pole 0.7: the
  /// four input tests 1–3 % each).
  bool passes = true;
};

/// The five Billings–Voon tests, an overall verdict and what a failure points to.
struct ResidualTests {
  CorrelationTest ee;    ///< φ_εε(τ) = E[ε(t−τ)·ε(t)], τ = 1..M: the residual is white
  CorrelationTest ue;    ///< φ_uε(τ) = E[u(t−τ)·ε(t)], τ = −M..M: no linear dependence on u left
  CorrelationTest u2e;   ///< φ_u²'ε(τ) = E[u²'(t−τ)·ε(t)], τ = −M..M: no even-order dependence on u left
  CorrelationTest u2e2;  ///< φ_u²'ε²(τ) = E[u²'(t−τ)·ε²'(t)], τ = −M..M: no odd-order dependence left
  CorrelationTest e_eu;  ///< φ_ε(εu)(τ) = E[ε(t)·ε(t−1−τ)·u(t−1−τ)], τ = 0..M: no nonlinear noise terms
  bool passes = true;             ///< all five pass
  bool input_tests_pass = true;   ///< the four tests involving u pass (φ_εε aside: coloured noise alone
                                  ///< is expected in a simulation residual)
  /// One line: what the failing tests point to, or that nothing was found.
  std::string explanation;
};

/// Runs the five tests on input `u` and residual `residual` (y − ŷ) for lags up to `max_lag`. Every signal
/// has its mean removed (u²' = u² − mean(u²)) and each φ is normalised by the root of the product of the
/// two signals' sums of squares (Billings & Voon 1986), so |φ| ≤ 1 and the band is ±1.96/√N.
/// Throws std::invalid_argument for unequal lengths, max_lag < 1, N < 4·(max_lag + 1), non-finite samples,
/// or a constant u, u², ε or ε².
ResidualTests residual_tests(const Eigen::VectorXd& u, const Eigen::VectorXd& residual, int max_lag = 20);

}  // namespace panelbass::models

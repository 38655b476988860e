#pragma once
// Correlation functions of signals, normalised, with their noise band.

#include <Eigen/Core>

namespace panelbass::dsp {

/// Normalised cross-correlation r(τ) = Σ_k (u(k)−ū)(y(k+τ)−ȳ) / (N·σ_u·σ_y) for τ = 0..max_lag.
/// For a white input this is the impulse response scaled by σ_u/σ_y. Throws std::invalid_argument for
/// unequal lengths, max_lag ≥ N, or a constant signal.
Eigen::VectorXd cross_correlation(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index max_lag);

/// Normalised autocorrelation of x for τ = 0..max_lag (r(0) = 1).
Eigen::VectorXd autocorrelation(const Eigen::VectorXd& x, Eigen::Index max_lag);

/// Half-width of the band that a normalised correlation of N samples of independent white signals
/// stays inside with two-sided probability `confidence` (z/√N; z from the normal quantile).
double correlation_noise_band(Eigen::Index samples, double confidence = 0.99);

}  // namespace panelbass::dsp

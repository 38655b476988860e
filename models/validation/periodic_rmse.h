#pragma once
// The fine steering mirror benchmark's score of a periodic multi-output record (nonlinear_benchmarks'
// FineSteeringMirror protocol, as its baseline notebook computes it): an RMSE per output, realisation and
// period over the samples after the initialisation window, averaged over realisations and periods, then
// over outputs.

#include <Eigen/Core>
#include <vector>

namespace panelbass::models {

/// The figures of a simulated periodic record against the measured one.
struct PeriodicScore {
  Eigen::VectorXd rmse;   ///< per output: mean over realisations and periods of each period's RMSE
  double mean_rmse = 0.0; ///< the mean of `rmse` over outputs: the benchmark's figure
  double j_pct = 0.0;     ///< [2A] J over the same samples, every output pooled, %
};

/// Scores `simulated` against `measured` (per realisation a (P·N)×p matrix: its P periods of N samples one
/// after the other), skipping the first `init` samples of every period. Throws std::invalid_argument for
/// unequal shapes, a length that is not P·N, init ≥ N, a zero-energy output or a non-finite simulation.
PeriodicScore periodic_score(const std::vector<Eigen::MatrixXd>& simulated, const std::vector<Eigen::MatrixXd>& measured,
                             Eigen::Index period, Eigen::Index init);

}  // namespace panelbass::models

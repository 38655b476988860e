#pragma once
// The performance figures of the thesis: J ([2A]), the share of the measured output's energy that a
// model's output misses, and J_c ([2C]), the share of the desired output's energy that a controlled
// system's output misses. Both on the signals as given: offset correction is preprocessing (ch. 3),
// done to a recording before it is compared, never inside a figure.
//
// Every J in panelbass is one of these functions (the seed's [2A] ratio written once):
//   j_percent            simulation J of one output channel (the free run against the measurement)
//   j_weighted_percent   the same with a weight per sample (harmonic weights of a control excitation)
//   j_ratio_percent      the ratio of energies already summed (a loss over windows, realisations, channels)
//   jc_percent           closed-loop J_c [2C] against a desired output
// A prediction J (one-step, series-parallel) is j_percent of the prediction, named `pred` where reported.
//
// The silent output, defined once: an output (or desired output) with no energy over the range makes J
// undefined — any model misses "all" of nothing — so every J throws std::invalid_argument
// "J: <channel> has no energy over the samples judged" naming the channel, never 0, NaN or +∞. The JSON key of a
// validation J is `j_val_pct` in a job's result (`J_val_pct` where a CLI result or a model's meta lists it beside
// its other figures).

#include <Eigen/Core>
#include <string>

namespace panelbass::models {

/// [2A] 100 · error_energy / output_energy: J from energies summed by the caller. Throws std::invalid_argument
/// naming `channel` when output_energy is not > 0 (the silent output) or either is not finite.
double j_ratio_percent(double error_energy, double output_energy, const std::string& channel = "the measured output");

/// [2A] J = Σ (y_model − y)² / Σ y², in percent, over samples [start, end). Throws std::invalid_argument
/// for unequal lengths, an empty range, a silent y (naming `channel`), or a non-finite model output.
double j_percent(const Eigen::VectorXd& y_model, const Eigen::VectorXd& y, Eigen::Index start = 0,
                 const std::string& channel = "the measured output");

/// [2A] weighted: Σ w·(y_model − y)² / Σ w·y², in percent, over samples [start, end); as j_percent, and throws
/// for a weight count that differs from y's or a negative weight.
double j_weighted_percent(const Eigen::VectorXd& y_model, const Eigen::VectorXd& y, const Eigen::VectorXd& weight,
                          Eigen::Index start = 0, const std::string& channel = "the weighted output");

/// [2C] J_c = Σ (y_desired − y)² / Σ y_desired² in percent, over k ≥ skip; with `weight`, each term times
/// w(k). Throws std::invalid_argument for unequal lengths, a weight count that differs, nothing left after
/// the skip, or a silent desired output.
double jc_percent(const Eigen::VectorXd& y, const Eigen::VectorXd& y_desired, Eigen::Index skip = 0,
                  const Eigen::VectorXd& weight = {});

}  // namespace panelbass::models

#pragma once
// Diagnosis, the augmentations: gray-box terms added to a linear simulation. A term is a static
// function g of an estimated state (or of the input), orthogonalised against the state itself so that
// it adds only what the linear model cannot, and passed through the baseline's own dynamics with a few
// lags: y_aug = y_lin + Σ_l c_l · q^(−l)·G(q)·g. Its coefficients are fitted by least squares.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "models/linear/transfer_function.h"

namespace panelbass::models {

/// The fixed vocabulary of physics a model can leave out (docs/transducer.md, docs/diagnosis.md).
enum class Effect {
  resonance,
  antiresonance,
  delay,
  cubic_stiffness,
  asymmetric_stiffness,
  force_factor,
  inductance,
  hysteresis,
  saturation,
  thermal_compression,
  dc_offset,
  static_nonlinearity,
  nonlinear_damping,        ///< Rms(v): near one resonance v³ looks like x³ from the drive; the current tells them apart
  asymmetric_force_factor,  ///< a coil offset, Bl(x) with an odd term: looks like x² or Le(x) from the drive; the current tells
  creep,                    ///< a viscoelastic suspension: the spring relaxes, the displacement rises far below resonance
};

/// The effect's id ("cubic_stiffness", …).
std::string to_string(Effect effect);

/// Every effect of the vocabulary, in the order docs/diagnosis.md lists them.
std::vector<Effect> all_effects();

/// The ids of all_effects() joined by ", ".
std::string vocabulary_text();

/// Which signal a term's function acts on.
enum class StateProxy {
  output = 0,       ///< the simulated output ŷ itself (a displacement sensor: Silverbox)
  integral = 1,     ///< ∫ŷ, leaky (velocity from an accelerometer)
  double_integral = 2,  ///< ∫∫ŷ, leaky (displacement from an accelerometer)
  input = 3,        ///< the input u (a drive stage: saturation)
};

/// The proxy's name ("output", "integral", "double_integral", "input").
std::string to_string(StateProxy proxy);

/// Where a static nonlinearity sits in a block structure (static_nonlinearity; saturation is the input's).
enum class Position {
  input,    ///< before the dynamics: Hammerstein
  output,   ///< after them: Wiener
  between,  ///< between two filters: Wiener–Hammerstein
};

/// The position's name ("input", "output", "between").
std::string to_string(Position position);

/// The static function of a static nonlinearity.
enum class Shape {
  knee,        ///< a change of slope beyond a knee (saturating or dead-zone-like, by the fitted slope)
  polynomial,  ///< z² and z³ (a polynomial of order 3)
};

/// One augmentation term and its fitted coefficients.
struct DiagnosisTerm {
  Effect effect = Effect::dc_offset;
  StateProxy proxy = StateProxy::output;
  double threshold = 0.0;   ///< saturation: the knee, in units of the normalised input
  double time_constant_s = 0.0;  ///< thermal_compression: the time constant of the power-driven state; creep: of the relaxation
  bool one_sided = false;   ///< saturation, static_nonlinearity: each side of the knee fitted on its own (a diode), not alike
  Position position = Position::input;  ///< static_nonlinearity: where it sits
  Shape shape = Shape::knee;            ///< static_nonlinearity: its static function
  /// static_nonlinearity, and a saturation behind the drive's filter: the filter before it (scaled input → its
  /// signal z; unit DC gain). Empty (no coefficients) for a saturation of the drive as sampled.
  TransferFunction front;
  TransferFunction back;    ///< with `front`: the filter after it (its output → the scaled output)
  double front_rms = 1.0;   ///< with `front`: rms of front·u on the estimation record (z is divided by it)
  Eigen::VectorXd coefficients;  ///< one per lag (dc_offset: one, the offset in scaled output units)
};

/// The signals a term is built from, in the baseline's scaled units, each of zero mean and unit rms
/// on the record they were normalised on.
struct StateSignals {
  Eigen::VectorXd input, output, integral, double_integral;
  Eigen::Vector4d mean = Eigen::Vector4d::Zero();  ///< subtracted from each, in proxy order
  Eigen::Vector4d rms = Eigen::Vector4d::Ones();   ///< divided into each, in proxy order
  double fs = 1.0;                                 ///< sample rate, Hz
  /// The signal of `proxy`.
  const Eigen::VectorXd& of(StateProxy proxy) const;
};

/// The state proxies from the scaled input `u` and the scaled simulated output `y_sim` at rate `fs`:
/// leaky integrators with their corner at fs/500 keep ∫ and ∫∫ bounded. With `reference`, its means and
/// rms are used (so that a validation record is normalised exactly as the estimation record was).
StateSignals state_signals(const Eigen::VectorXd& u, const Eigen::VectorXd& y_sim, double fs,
                           const StateSignals* reference = nullptr);

/// y = B(q)/A(q)·x from rest.
Eigen::VectorXd filter_through(const TransferFunction& tf, const Eigen::VectorXd& x);

/// The static feature g of `term` (before filtering): z³ (cubic stiffness), z² (asymmetric stiffness),
/// z²·u (force factor), z·Δu (inductance), tanh of the motion's direction (hysteresis), the drive beyond a
/// knee (saturation), u times a slow power-driven state (thermal compression), or a constant; orthogonalised
/// against z and u where they carry a linear part.
Eigen::VectorXd term_feature(const DiagnosisTerm& term, const StateSignals& states);

/// Features of a term: 2 for a static nonlinearity's polynomial (z², z³), for asymmetric_force_factor (x·u, x·v), for force_factor (x²·u, x²·v), inductance (z·Δu, u²) and a one-sided saturation
/// (each side of the knee with its own coefficients), else 1.
int feature_count(const DiagnosisTerm& term);

/// Whether `term`'s static function sits between filters of its own (`front`, `back`): a static nonlinearity, or a
/// saturation behind the drive's filter; its output then passes `back` instead of the baseline's dynamics.
bool has_block_filters(const DiagnosisTerm& term);

/// Whether `term`'s regressors read the input alone (a constant, a function of the drive or of the drive through
/// a filter of its own), so that a new estimate of the output's states leaves them unchanged.
bool reads_only_the_input(const DiagnosisTerm& term);

/// The signal z a static function acts on: with block filters (has_block_filters) the normalised input through the
/// filter before it, over front_rms; without (a saturation of the drive as sampled) its state proxy.
Eigen::VectorXd static_nonlinearity_signal(const DiagnosisTerm& term, const StateSignals& states);

/// Every static feature of `term` (feature_count columns; the first is term_feature).
Eigen::MatrixXd term_features(const DiagnosisTerm& term, const StateSignals& states);

/// Samples by which a term may lead the baseline's dynamics: the baseline's path from the drive includes
/// converter latency and filters that a force acting on the mechanics does not pass.
inline constexpr int kTermLead = 5;

/// The regressors of `term`: each of its features through `dynamics`, shifted by −kTermLead..lags−1
/// samples (term_columns columns; dc_offset: one column of ones).
Eigen::MatrixXd term_regressors(const DiagnosisTerm& term, const StateSignals& states,
                                const TransferFunction& dynamics, int lags);

/// Columns (coefficients) of `term` with `lags` lags: feature_count·(lags + kTermLead), dc_offset 1.
int term_columns(const DiagnosisTerm& term, int lags);

}  // namespace panelbass::models

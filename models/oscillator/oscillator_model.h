#pragma once
// A continuous-time oscillator driven by its band-limited input and sampled (the grey-box Duffing model of
// the Silverbox, a mass on a nonlinear spring and damper; docs/identification.md), in scaled units with
// time in samples:
//   ẏ = v,   v̇ = −d·v − k·y − Σ_i c_i·φ_i(y, v) + g·(ũ(t − τ) + u₀),
//   ŷ[k] = (1 − Σ_i h_i)·y[k] + Σ_{i=1..L} h_i·y[k−i] + Σ_{i=0..M−1} b_i·u[k−i] + y₀,
// ũ the input reconstructed band-limited between samples (BandLimitedInput), τ a delay, φ_i named terms of
// the restoring force (a cubic spring y³, a damping v·ln|v|, …), integrated by the classical Runge–Kutta
// method with a few substeps per sample; the output filter h (gain 1 at DC) and the input taps b are what a
// sensor and the amplifier add around the oscillator. Samples before a record's first count as its first.
// A run differentiates its outputs exactly (the RK4 recursion's own sensitivities) with respect to the
// parameters θ and the initial state x(0) = (y, v), for Levenberg–Marquardt.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/oscillator/band_limited_input.h"
#include "models/preprocess/scaling.h"

namespace panelbass::models {

/// A term φ(y, v) of the restoring force beyond the linear spring k·y and damper d·v.
enum class OscillatorTerm {
  y2,       ///< y²: an asymmetric spring
  y3,       ///< y³: a hardening (or softening) cubic spring, the Duffing term
  y_abs_y,  ///< y·|y|: a spring stiffening in proportion to the displacement
  v_log_v,  ///< v·ln|v|: a damping whose coefficient falls with speed (empirical, Silverbox)
  y_v,      ///< y·v: a damping that depends on the displacement's sign
  v2,       ///< v²: an asymmetric damping
  y_v2,     ///< y·v²
  v_y2,     ///< v·y²: a damping growing with the displacement
};

/// The term's name in files and on the command line: "y2", "y3", "y_abs_y", "v_log_v", "y_v", "v2", "y_v2", "v_y2".
const char* oscillator_term_name(OscillatorTerm term);
/// The term named `name`; std::invalid_argument listing the names otherwise.
OscillatorTerm oscillator_term_from_name(const std::string& name);

/// φ(y, v) and its partial derivatives.
struct OscillatorTermValue {
  double value = 0.0, dy = 0.0, dv = 0.0;
};
/// φ of `term` at (y, v) (v·ln|v| is taken as v·½·ln(v² + 10⁻³⁰), finite at v = 0).
OscillatorTermValue oscillator_term(OscillatorTerm term, double y, double v);

/// What an oscillator model has beyond its linear spring, damper and gain.
struct OscillatorStructure {
  std::vector<OscillatorTerm> terms;  ///< φ_i, each at most once
  int substeps = 4;                   ///< RK4 steps per sample (1–64)
  int output_taps = 0;                ///< L: h_1 … h_L (0–64)
  int input_taps = 0;                 ///< M: b_0 … b_{M−1} (0–64)

  /// Number of parameters P of θ.
  Eigen::Index parameter_count() const;
  /// θ's index of c_i (term i), h_1 and b_0.
  Eigen::Index term_index(std::size_t i) const;
  Eigen::Index output_tap_index() const;
  Eigen::Index input_tap_index() const;
  /// Throws std::invalid_argument naming the size out of range or the term given twice.
  void check() const;
};

/// θ's fixed entries, in order; the terms' c_i follow, then h_1 … h_L, then b_0 … b_{M−1}.
enum OscillatorParameter : Eigen::Index {
  kOscDamping,       ///< d
  kOscStiffness,     ///< k
  kOscGain,          ///< g
  kOscInputOffset,   ///< u₀
  kOscOutputOffset,  ///< y₀
  kOscDelay,         ///< τ, samples
  kOscFixedParameters,
};

/// What a run differentiates.
enum class OscillatorSensitivity {
  none,           ///< the outputs alone
  initial_state,  ///< ∂ŷ/∂x(0): 2 columns
  all,            ///< ∂ŷ/∂[x(0); θ]: 2 + P columns
};

/// The outputs of one run and their derivatives.
struct OscillatorRun {
  Eigen::VectorXd y;         ///< ŷ[k], scaled units
  Eigen::MatrixXd jacobian;  ///< rows k, columns as OscillatorSensitivity says (empty for none)
  std::optional<Eigen::Index> diverged;  ///< the sample where the state left ±kOscillatorBound (outputs after it 0)
};

/// How far (scaled units) an oscillator's displacement or velocity may go before a run counts as diverged.
inline constexpr double kOscillatorBound = 1e4;

/// Runs the oscillator of structure `s` and parameters `theta` on `input` from x(0) = `x0` for `samples`
/// samples (−1: all of the input's), differentiating as `which` says.
OscillatorRun oscillator_run(const OscillatorStructure& s, const Eigen::VectorXd& theta, const BandLimitedInput& input,
                             const Eigen::Vector2d& x0, OscillatorSensitivity which, Eigen::Index samples = -1);

/// x(0) fitted by Levenberg–Marquardt so that the model's first `init` outputs match `y` (scaled) in least
/// squares (the benchmarks' protocol for a model without a state estimator); x(0) = 0 when init is 0.
Eigen::Vector2d oscillator_initial_state(const OscillatorStructure& s, const Eigen::VectorXd& theta,
                                         const BandLimitedInput& input, const Eigen::VectorXd& y, Eigen::Index init);

/// An oscillator model in scaled units, with what it needs for raw data.
struct OscillatorModel {
  OscillatorStructure structure;
  Eigen::VectorXd theta;  ///< laid out as OscillatorParameter says
  Scaling scaling;
  double fs = 0.0;
  nlohmann::json meta = nlohmann::json::object();

  /// Free run in scaled units: from rest (x(0) = 0) when init is 0, else from the x(0) fitted to the first
  /// `init` measured outputs (which are returned in their place). Throws std::runtime_error naming the
  /// sample where the run diverged.
  Eigen::VectorXd simulate_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& y = {}, Eigen::Index init = 0) const;
  /// simulate_scaled on an input already reconstructed (scaled units), to run one record many times.
  Eigen::VectorXd simulate_scaled(const BandLimitedInput& input, const Eigen::VectorXd& y, Eigen::Index init) const;
  /// Free run on raw data, raw units; the first `init` measured outputs (raw) set the state.
  Eigen::VectorXd simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y = {}, Eigen::Index init = 0) const;
  /// One-step prediction on raw data: an output-error model's predictor is its free run (its noise model is
  /// 1), here with x(0) fitted to the first min(50, N) measured outputs.
  Eigen::VectorXd predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const;

 private:
  /// The run (scaled) from the x(0) fitted to the first `init` outputs of `y`; std::runtime_error naming the sample
  /// where it diverged.
  Eigen::VectorXd run_from_fitted_state(const BandLimitedInput& input, const Eigen::VectorXd& y, Eigen::Index init) const;
};

/// {"format":"panelbass.model/1","kind":"oscillator","fs","scaling","params":{"substeps","damping","stiffness",
/// "gain","input_offset","output_offset","delay","terms":[{"term": name,"coefficient": c}…],
/// "output_fir":[h_1…h_L],"input_fir":[b_0…b_{M−1}]},"meta"} (time in samples, scaled units).
nlohmann::json oscillator_model_to_json(const OscillatorModel& m);

/// Reads and validates an oscillator model object: the structure, every parameter finite, fs > 0, and a
/// bounded free run on full-scale noise; ConfigError names the key.
OscillatorModel oscillator_model_from_json(const nlohmann::json& j);

}  // namespace panelbass::models

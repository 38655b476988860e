#pragma once
// The thesis's linear controller (ch. 7): LQ state feedback on the linear model ([7A]) used as a
// feedforward controller ([7B], fig. 7.2), with the largest program amplitude that keeps its output
// within the model's valid range [−1, 1] behind a band-pass (fig. 7.8 and its table).
//
// Units: the design is done on the linear model's realisation in its scaled units (the thesis's units,
// ch. 3); the controller's input u and output u* are in raw drive units (the model's input scale is
// folded into B and L; offsets are left out, the controller acts on a zero-mean program).

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <vector>

#include "dsp/biquad.h"
#include "models/linear/linear_model.h"
#include "models/control/riccati.h"
#include "models/linear/state_space.h"

namespace panelbass::models {

/// The weights of [7A]: V_c = Σ y(k)·R0·y(k) + u(k)·R·u(k), i.e. Q = Cᵀ·R0·C.
struct LqWeights {
  double R = 3.0;    ///< weight on the controller output u* (R > 0)
  double R0 = 20.0;  ///< weight on the model output y (R0 ≥ 0)
};

/// A target band for the desired response (fig. 7.10's y_desired): a Butterworth high-pass, flat above.
struct LqTargetBand {
  double highpass_hz = 0.0;  ///< the high-pass corner, Hz, in (0, fs/2)
  int order = 2;             ///< its Butterworth order, 1…8
  double mid_hz = 0.0;       ///< where the target's gain is set to the model's (in (0, fs/2))
};

/// The reference model the LQ design tracks instead of regulating y to 0 (empty: the thesis's [7A]).
struct LqTarget {
  LqTargetBand band;         ///< what the user asked for
  double gain = 0.0;         ///< signed: the model's gain at band.mid_hz, raw units (the sign keeps its phase)
  int delay = 0;             ///< samples: the model's delay (nk plus leading zero coefficients), at least 1
  StateSpace model;          ///< program (raw) → y_r (raw): gain·z^−delay·high-pass, realised
  Eigen::RowVectorXd L;      ///< feedback on the reference model's states, raw drive units per state
  double feedthrough = 1.0;  ///< u*(k)'s term in the program u(k)
};

/// An LQ feedforward controller designed on a linear model.
struct LqFeedforward {
  StateSpace plant;        ///< the linear model realised in raw units: u (drive) → y (raw output)
  Eigen::RowVectorXd L;    ///< state feedback, raw drive units per state
  LqWeights weights;       ///< the weights it was designed with
  double fs = 0.0;         ///< sample rate, Hz
  nlohmann::json meta = nlohmann::json::object();  ///< provenance (model file, band-pass, …)
  LqTarget target;         ///< the tracked target band (target.model.order() == 0: none, flat [7A]/[7B])

  /// True when the design tracks a target band (target.model has states).
  bool has_target() const { return target.model.order() > 0; }
  /// [7B] u → u*:  x(k+1) = (A − BL)·x(k) + B·u(k),  u*(k) = −L·x(k) + u(k); with a target, the state is
  /// [x; x_r], x_r(k+1) = A_r·x_r(k) + B_r·u(k) and u*(k) = −L·x(k) − L_r·x_r(k) + l·u(k).
  StateSpace controller() const;
  /// [7B] u → y_lin: x(k+1) = (A − BL)·x(k) + B·u(k),  y_lin(k) = (C − D·L)·x(k) + D·u(k): the desired
  /// response (the model driven by u*; the thesis's D = 0 makes it C·x(k)); with a target, the model
  /// driven by controller()'s u*.
  StateSpace desired() const;
  /// Poles of the controlled system: eigenvalues of A − BL (and, with a target, the reference model's).
  Eigen::VectorXcd poles() const;
  /// Finite zeros of the controller u*/u (without a target: the poles of the plant model, which it cancels).
  Eigen::VectorXcd zeros() const;
};

/// Designs the controller of [7A]/[7B] on `model` (balanced realisation in scaled units, Q = Cᵀ·R0·C);
/// throws std::invalid_argument for R ≤ 0, R0 < 0, non-finite weights or an unstable model.
LqFeedforward design_lq(const LinearModel& model, const LqWeights& weights);

/// [7A] as a tracking problem: the model's output y follows y_r = gain·z^−delay·HP(z)·u, HP the Butterworth
/// high-pass of `band` (dsp::butterworth_highpass), gain the model's at band.mid_hz (signed to the nearer
/// phase), delay the model's. The augmented state [x; x_r] with the program u(k) known when u*(k) is chosen:
/// minimises Σ R0·(y − y_r)² + R·u*² for a white program. Throws std::invalid_argument as design_lq does,
/// and for a corner or mid frequency outside (0, fs/2) or an order outside 1…8.
LqFeedforward design_lq(const LinearModel& model, const LqWeights& weights, const LqTargetBand& band);

/// The largest program amplitudes that keep u* within [−1, 1] behind `band_pass` (empty: none).
struct InputLimits {
  double worst = 0.0;  ///< for any input: 1 / ‖h‖₁, h the impulse response program → u*
  double noise = 0.0;  ///< for uniform white noise: 1 / max|u*| over the record of unit-amplitude noise
};

/// The table after fig. 7.8: the worst case from the impulse response of band-pass · controller (summed
/// until its tail is below 1e-12 of the sum, at most 10⁶ samples), and the band-limited white-noise case
/// from `samples` samples of uniform noise in [−1, 1] drawn with `seed` (dsp::Rng), both chains from
/// rest. Throws std::invalid_argument for samples < 1, an unstable controller or band-pass section.
InputLimits max_input(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass,
                      Eigen::Index samples = 100000, std::uint64_t seed = 1);

/// The estimated peak excursion for the noise of max_input() at program peak 1: the desired response
/// y_lin (the model's output, acceleration) to the band-passed noise, integrated twice by
/// dsp::leaky_integral (an integrator above fs/500), its largest magnitude, in the model output's units × s².
/// The linear model scales it with the program's level. Throws std::invalid_argument for samples < 1.
double noise_excursion(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass,
                       Eigen::Index samples = 100000, std::uint64_t seed = 1);

/// Where the drive u* = (controller · band-pass)(program) is loudest for a sine: its gain's peak.
struct DrivePeak {
  double frequency_hz = 0.0;  ///< where |band-pass · controller| is largest
  double gain_db = 0.0;       ///< that gain, dB (≤ 20·log10 ‖h‖₁ = −20·log10 InputLimits::worst)
};

/// The peak of |band-pass · controller| on a logarithmic grid of 2000 frequencies from 1 Hz to just below
/// Nyquist. Below the band-pass's low corner it means the controller boosts what the band-pass removes.
DrivePeak drive_peak(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass);

/// Where the controller's gain |u*/u| passes through 1 (0 dB), ascending, from 1 Hz to just below Nyquist:
/// the bands it boosts and those it cuts, as the thesis reads fig. 7.7 ("all the frequencies below 70 Hz
/// will be amplified, while input frequencies between 70-600 Hz will be quenched"). Found on drive_peak's
/// grid, each refined by bisection to 1e-9 relative; empty when the gain never crosses 1 there.
std::vector<double> unity_gain_hz(const LqFeedforward& ff);

/// {"format":"panelbass.model/1","kind":"lq_feedforward","fs",
///  "params":{"A":[[…]],"B":[…],"C":[…],"D","L":[…],"R","R0"[,"target":{"highpass_hz","order","mid_hz",
///  "gain","delay","A","B","C","D","L","feedthrough"}]},"meta"}.
nlohmann::json lq_feedforward_to_json(const LqFeedforward& ff);
/// Reads and validates an LQ feedforward object: shapes, finite entries, fs > 0 and a stable A − BL;
/// ConfigError names the key ("model.params.L: 7 entries, A has 8 states").
LqFeedforward lq_feedforward_from_json(const nlohmann::json& j);

}  // namespace panelbass::models

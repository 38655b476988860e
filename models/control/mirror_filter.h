#pragma once
// Klippel's mirror filter: the exact inverse of an identified nonlinear state model of the exciter
// (voltage → current → force Bl(x)·i → mass-spring with K(x), Le(x, i), friction), run in feedforward
// sample by sample. A linear reference model (the same model with every element at its rest value)
// is driven by the program; the filter solves the nonlinear model's mechanical equation for the
// current that produces the reference's motion, then its electrical equation for the drive that
// produces that current. On a plant the model describes exactly, the output is the linear model's.
//
// The model is gray-box and discrete (one step per sample, drive held over the sample), in drive units
// and displacement in mm, so that it can be fitted by linear least squares to a record of drive, coil
// current and displacement alone (fit_mirror_model), with no knowledge of the amplifier's gain or of
// the moving mass:
//   [M1] w_k = E_L(x_k, i_k)·(i_{k+1} − i_k)/h + e_R·i_{k+1} + E_v(x_{k+1}, i_k)·v_{k+1} + u_{b,k}
//        (the back-EMF at the end of the sample, where the current is taken: v_{k+1} = (x_{k+1} − x_k)/h),
//        u_{b,k} = r_b·(1 − p)/ρ·(i_{k+1} − j_k),  j_{k+1} = p·j_k + (1 − p)·i_{k+1},  p = e^{−ρ}
//        (an eddy-current branch, an inductance L2 parallel to a resistance R2 in series with the coil: r_b = R2/gain,
//        ρ = h·R2/L2, j the current in L2; with the current held at i_{k+1} over the sample, j relaxes exactly so and
//        u_b is the branch's voltage R2·(i − j) averaged over the sample; none when r_b = 0),
//        w_k = Σ_{j<4} a_j·drive_{k−j}, a_0 = 1 (the DA path: its filter and the fraction of a sample of delay
//        that the whole-sample delay leaves, as a short minimum-phase FIR, so that the filter can invert it)
//        E_L = e0 + e1·x + e2·x² + e3·i²          (Le(x, i) / gain)
//        E_v = e5 + e6·x + e7·x² + e8·i + e9·i·x  (Bl(x)/gain and i·dLe/dx / gain)
//   [M2] v_{k+1} = v_k + h·M(x_k, v̄_k, i_k),  v̄_k = (v_k + v_{k+1})/2 the velocity at the sample instant
//        M = c0·i + c1·i·x + c2·i·x² + c3·i² + c4·i²·x + c5·v + c6·x + c7·x² + c8·x³ + c9·tanh(v/v0) + c10·v³
//        (Bl(x)·i, reluctance force ½i²·dLe/dx, damping, K(x)·x, Coulomb friction, the mechanical resistance's rise
//        with velocity Rms(v) = Rms·(1 + r2·v²) — all over the mass)
//   [M3] x_{k+1} = x_k + h·v_{k+1}
// The mirror runs the reference one step ahead: at k it knows the reference's state at k+1 (and, its [M2] being
// linear, its velocity at k+2), solves [M2] at k+1 for the current ĩ_{k+1} that gives the reference's next
// acceleration, [M1] at k for the w that makes it, and the drive from w by 1/A(z).
// The linear reference keeps e0, e_R, e5, c0, c5, c6 and the eddy-current branch, and drops every other coefficient. A
// file's mechanical list may stop at c9 (written before issue #56's third session): c10 is then 0; a file without
// "eddy" (written before its fourth) has no branch.
//
// The record is of a continuous plant sampled: its second difference (x_{k+1} − 2x_k + x_{k−1})/h² is the
// acceleration averaged over two samples with a triangular weight, which shrinks a component at f by
// sinc²(f/fs) (8 % at 480 Hz, the third harmonic of 160 Hz, at 3 kHz). [M2] is therefore fitted with each
// regressor row weighted as Numerov's method has it, (row_{k−1} + 10·row_k + row_{k+1})/12, which gives the
// continuous coefficients (the plant's K/m, Bl/m and nonlinear shapes to ~0.1 %), and every coefficient of
// [M2] is then scaled by (2 − 2·cos ω₀h)/(ω₀h)², ω₀² = −c6, so that the one-step recursion's resonance is the
// plant's (issue #34: 80 Hz 20.5 → 26 dB, 160 Hz 11.4 → 19 dB on panel-exciter without sensor noise).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>

namespace panelbass::models {

/// What the adaptation measures: the sensor (mirror_observer.h's extended Kalman filter) or the coil current
/// (mirror_current_adapter.h's Kalman filter on the scales).
enum class MirrorMeasurement { sensor, current };

/// What the on-line adaptation needs: with the sensor, the sensor map [S1] and the noise it weighs by (the observer,
/// mirror_observer.h); with the current, its lag and its noise (mirror_current_adapter.h).
struct MirrorObserverSettings {
  bool enabled = false;               ///< adapt the model on line (from the sensor, or the current)
  std::array<double, 4> sensor_taps{};  ///< s_0..s_3 of [S1], sensor units per mm/s
  double sensor_noise = 0.0;          ///< the sensor's noise, rms, sensor units
  double process_noise = 0.0;         ///< the model's acceleration error, rms, mm/s²
  double stiffness_rate = 1e-4;       ///< θ_K's random walk, standard deviation per sample
  double stiffness_spread = 0.3;      ///< θ_K's initial standard deviation (around 1)
  double force_rate = 1e-4;           ///< θ_F's random walk, standard deviation per sample
  double force_spread = 0.1;          ///< θ_F's initial standard deviation (around 1)
  double nonlinear_rate = 1e-4;       ///< θ_N's random walk, standard deviation per sample
  double nonlinear_spread = 0.3;      ///< θ_N's initial standard deviation (around 1)
  MirrorMeasurement measurement = MirrorMeasurement::sensor;  ///< what the adaptation reads
  int current_lag = 0;                ///< with the current: its lag L behind the drive, samples (−1..6)
  double current_noise = 0.0;         ///< with the current: the model's current error, rms, A
  double scale_rate = 2e-4;           ///< with the current: each scale's random walk, standard deviation per sample
  double scale_spread = 0.2;          ///< with the current: each scale's initial standard deviation (around 1)
};

/// [M1]'s eddy-current branch: an inductance L2 parallel to a resistance R2, in series with the coil.
struct MirrorEddyBranch {
  double resistance = 0.0;  ///< r_b = R2 over the amplifier's gain (e_R's units); 0: no branch
  double rate = 1.0;        ///< ρ = h·R2/L2, the branch's relaxation per sample (> 0)
  /// True when the model has the branch.
  bool present() const noexcept { return resistance != 0.0; }
};

/// The identified gray-box exciter model of [M1]–[M3] (x in mm, v in mm/s, i in A, drive dimensionless).
struct MirrorModel {
  double fs = 3000.0;                ///< sample rate, Hz
  std::array<double, 10> electrical{};  ///< e0..e9 of [M1]; e4 is e_R (the coil resistance over the gain)
  std::array<double, 11> mechanical{};  ///< c0..c10 of [M2]
  double friction_velocity = 50.0;   ///< v0 of the friction term, mm/s
  int delay = 0;                     ///< samples between the drive and the coil voltage found by the fit
  std::array<double, 4> drive_taps{1.0, 0.0, 0.0, 0.0};  ///< a_0..a_3 of [M1]'s A(z) (a_0 = 1, minimum phase)
  MirrorEddyBranch eddy;             ///< [M1]'s eddy-current branch (none unless fitted)
  MirrorObserverSettings observer;   ///< the on-line stiffness adaptation (off unless fitted with a sensor)
  /// The same model with every nonlinear coefficient zero: the linear reference.
  MirrorModel linear() const;
};

/// Scales on a model's coefficients, each 1 for the model as fitted (an adaptation's estimates).
struct MirrorScales {
  double stiffness = 1.0;     ///< θ_K: K(x), c6–c8 of [M2] (the resonance)
  double force = 1.0;         ///< θ_F: the linear force factor over the mass, c0 of [M2]
  double nonlinear = 1.0;     ///< θ_N: every nonlinear coefficient, c1–c4, c7–c10 of [M2] and e1–e3, e6–e9 of [M1]
  double resistance = 1.0;    ///< θ_R: the coil's resistance e_R (e4; its temperature)
  double force_factor = 1.0;  ///< θ_B: Bl(x) in both equations, c0–c2 of [M2] and e5–e7 of [M1]
};

/// The model with its coefficients scaled by `scales`.
MirrorModel with_scales(MirrorModel model, const MirrorScales& scales) noexcept;

/// One step of the model's state (current A, displacement mm, velocity mm/s).
struct MirrorState {
  double i = 0.0, x = 0.0, v = 0.0;
  std::array<double, 3> past{};  ///< drive_{k−1..k−3}, for [M1]'s A(z)
  double eddy = 0.0;  ///< j, the current in the eddy-current branch's inductance, A
};

/// [M1]'s eddy-current branch in one step: u_b = resistance·(i_{k+1} − j_k) and j_{k+1} = pole·j_k + (1 − pole)·i_{k+1}.
struct EddyStep {
  double resistance = 0.0;  ///< r_b·(1 − p)/ρ (0: no branch)
  double pole = 1.0;        ///< p = e^{−ρ}
};

/// The branch's step coefficients for `branch` (none: resistance 0).
EddyStep eddy_step(const MirrorEddyBranch& branch) noexcept;

/// Steps [M1]–[M3] once with `drive` held; returns the acceleration (v_{k+1} − v_k)/h, mm/s².
double step_mirror_model(const MirrorModel& model, MirrorState& state, double drive) noexcept;

/// The same with the eddy-current branch's step given (eddy_step(model.eddy), computed once by a caller that steps often).
double step_mirror_model(const MirrorModel& model, const EddyStep& eddy, MirrorState& state, double drive) noexcept;

/// The mirror filter on a model: program sample in, drive sample out, allocation-free and noexcept.
class MirrorFilter {
 public:
  /// A filter at rest for `model` (the linear reference is model.linear()).
  explicit MirrorFilter(const MirrorModel& model);
  /// The drive that makes the nonlinear model follow the linear reference driven by `program`.
  double process(double program) noexcept;
  /// Back to rest.
  void reset() noexcept;
  /// True when the last sample's force equation had no real solution (the current was clamped to the
  /// linear one), or the model's force factor Bl(x) had fallen below a quarter of its rest value there (it was
  /// held at that quarter): the program asks for more than the model's force factor can give.
  bool saturated() const { return saturated_; }
  /// Scales the stiffness K(x) and the linear force factor c0 of both the model and its linear reference (the
  /// resonance and the gain move with them) by `stiffness` and `force`, and the model's nonlinear coefficients by
  /// `nonlinear`, relative to the model the filter was made with (as with_scales of mirror_observer.h);
  /// allocation-free.
  void set_scales(double stiffness, double force, double nonlinear) noexcept;
  /// The same with every scale of `scales` (the linear reference takes the scaled model's linear coefficients).
  void set_scales(const MirrorScales& scales) noexcept;

 private:
  MirrorModel base_, model_, reference_;
  MirrorState ref_;
  double current_ = 0.0;  // the nonlinear model's current, ĩ_k
  double eddy_current_ = 0.0;  // its eddy-current branch's j_k
  EddyStep eddy_;  // the branch's step (the same for the model and its reference)
  std::array<double, 3> past_{};  // the filter's drive_{k−1..k−3}, for 1/A(z)
  bool saturated_ = false;
};

/// True when every root of z³ + a1·z² + a2·z + a3 (A(z) = 1 + a1·z⁻¹ + a2·z⁻² + a3·z⁻³) lies inside |z| < 0.95:
/// 1/A(z), how the filter inverts the drive path, is then stable with some margin.
bool minimum_phase(const std::array<double, 4>& a);

/// Runs the mirror filter over `program` from rest.
Eigen::VectorXd mirror_filter(const MirrorModel& model, const Eigen::VectorXd& program);

/// Simulates the model [M1]–[M3] from rest on `drive`; returns the acceleration, mm/s².
Eigen::VectorXd simulate_mirror_model(const MirrorModel& model, const Eigen::VectorXd& drive);

/// The model's states along a free run: index k holds the state at the start of sample k (i A, x mm, v mm/s) and
/// the acceleration over sample k, (v_{k+1} − v_k)/h in mm/s².
struct MirrorRun {
  Eigen::VectorXd i, x, v, a;
};

/// Runs the model [M1]–[M3] from rest on `drive` held `lag` samples late (zero outside the record) into `out`
/// (resized, so that a caller running many times reuses its memory); false when the current's magnitude reaches
/// `current_bound` or leaves the finite (the run stops there and the rest of `out` is NaN) or x or v leave the finite.
bool run_mirror_model(const MirrorModel& model, const Eigen::VectorXd& drive, Eigen::Index lag, MirrorRun& out,
                      double current_bound = std::numeric_limits<double>::infinity());

/// The same, returned, with no bound: NaN from where the current left the finite.
MirrorRun run_mirror_model(const MirrorModel& model, const Eigen::VectorXd& drive, Eigen::Index lag = 0);

/// How a gray-box fit went.
struct MirrorFit {
  MirrorModel model;               ///< the fitted model
  double electrical_fit_pct = 0.0; ///< J [2A] of [M1] solved for the current: its residual's energy over the current's, %
  double mechanical_fit_pct = 0.0; ///< J [2A] of [M2]: its residual's energy over the acceleration's, %
  double mechanical_residual_rms = 0.0;  ///< rms of [M2]'s residual, mm/s²
};

/// What a record to fit is: a continuous plant sampled (a transducer, the virtual one; [M2] fitted with Numerov's
/// weights and its resonance matched, see above) or the discrete model [M1]–[M3] itself (fitted as it is).
enum class MirrorRecordKind { sampled_plant, discrete_model };

/// Fits [M1]–[M3] to a record of `drive`, coil `current` (A) and `displacement` (m) at `fs` by linear least
/// squares (velocity from the displacement's differences, as [M3] has it), choosing the drive's delay in
/// 0..max_delay samples, the length of A(z) (1–4 taps, kept only when minimum phase) and the friction velocity
/// scale on a grid by the smallest residual. Throws
/// std::invalid_argument naming the problem for columns of unequal length, fewer than 1000 samples, a
/// non-finite sample, or a current or displacement without energy (J's silent output, validation/performance.h).
MirrorFit fit_mirror_model(const Eigen::VectorXd& drive, const Eigen::VectorXd& current,
                           const Eigen::VectorXd& displacement, double fs, int max_delay = 4,
                           MirrorRecordKind kind = MirrorRecordKind::sampled_plant);

/// The model file {"format":"panelbass.model/1","kind":"mirror_filter","fs",…,"params":{…},"meta"}.
nlohmann::json mirror_model_to_json(const MirrorModel& model, const nlohmann::json& meta = nlohmann::json::object());

/// Reads a mirror_filter model file; ConfigError naming the key for anything missing or not finite.
MirrorModel mirror_model_from_json(const nlohmann::json& json);

}  // namespace panelbass::models

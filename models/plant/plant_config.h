#pragma once
// Configuration of the virtual transducer: a moving-magnet exciter on a panel, with switchable
// nonlinear terms, panel modes, converters and a sensor (see docs/transducer.md).

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace panelbass::models {

/// Common switch of a nonlinear term: `scale` multiplies its deviation from the linear plant
/// (0 = linear, 1 = nominal, 2 = twice as strong).
struct NonlinearSwitch {
  bool enabled = false;
  double scale = 1.0;
  /// The factor applied to the term's deviation: scale when enabled, else 0.
  double gain() const { return enabled ? scale : 0.0; }
};

/// K(x) = K0·(1 + s·(k1·x + k2·x²)), x in mm: k2 > 0 hardens, k1 makes it asymmetric.
struct StiffnessTerm : NonlinearSwitch {
  double k1_per_mm = 0.0;
  double k2_per_mm2 = 0.0;
};

/// Bl(x) = Bl0·(1 + s·(b1·x + b2·x²)), x in mm: b2 < 0 as the coil leaves the gap.
struct ForceFactorTerm : NonlinearSwitch {
  double b1_per_mm = 0.0;
  double b2_per_mm2 = 0.0;
};

/// Le(x, i) = Le0·(1 + s·(l1·x + l2·x² + li2·i²)), x in mm, i in A.
struct InductanceTerm : NonlinearSwitch {
  double l1_per_mm = 0.0;
  double l2_per_mm2 = 0.0;
  double li2_per_A2 = 0.0;
};

/// Friction force s·Fc·tanh(v / v0): depends on the direction of motion (hysteresis in x).
struct FrictionTerm : NonlinearSwitch {
  double coulomb_N = 0.0;
  double velocity_scale_m_per_s = 0.05;
};

/// The amplifier clips its input above `level` (drive units) with a soft knee of width `knee`.
struct ClippingTerm : NonlinearSwitch {
  double level = 1.0;
  double knee = 0.05;
};

/// Re(T) = Re0·(1 + s·α·T), T' = (Re·i²·Rth − T)/τ: thermal compression.
struct ThermalTerm : NonlinearSwitch {
  double alpha_per_K = 0.00393;
  double resistance_K_per_W = 10.0;
  double time_constant_s = 2.0;
};

/// Rms(v) = Rm·(1 + s·r2·v²), v in m/s: the mechanical resistance rising with velocity (nonlinear damping).
struct DampingTerm : NonlinearSwitch {
  double r2_per_m2ps2 = 0.0;
};

/// Creep of a viscoelastic suspension (linear): the spring relaxes towards a softer one, F = K0·(x − c·z) with
/// τ·dz/dt = x − z, so that far below 1/(2πτ) the stiffness is K0·(1 − c) and the displacement rises. Off at c = 0.
struct CreepTerm {
  double fraction = 0.0;          ///< c, the share of K0 that relaxes (0 ≤ c < 1; 0: no creep)
  double time_constant_s = 0.01;  ///< τ
};

/// All nonlinear terms of the plant.
struct NonlinearTerms {
  StiffnessTerm stiffness;
  ForceFactorTerm force_factor;
  InductanceTerm inductance;
  FrictionTerm friction;
  ClippingTerm clipping;
  ThermalTerm thermal;
  DampingTerm damping;  ///< off unless a plant file switches it on (presets and renders do not change)
};

/// A structural panel mode driven by the coil force: q̈ + 2ζω q̇ + ω² q = g·F/m; it adds q̈ to the
/// measured acceleration.
struct PanelMode {
  double frequency_hz = 1000.0;
  double damping_ratio = 0.02;
  double gain = 0.2;
};

/// An analog Butterworth low-pass (order 0 = none).
struct AnalogFilter {
  int order = 4;
  double cutoff_hz = 1200.0;
};

/// DA reconstruction and AD anti-alias filters, and the converters' latency.
struct Converters {
  AnalogFilter da_filter;
  AnalogFilter ad_filter;
  int delay_samples = 1;   ///< whole samples of latency between the drive and the DA output
};

/// What the sensor reads. Each reading includes the panel modes' share (q̈, q̇ or q added to the exciter's own).
enum class SensorKind {
  acceleration,  ///< an accelerometer on the panel (the default): V per m/s²
  velocity,      ///< a velocity pick-up (a laser vibrometer's velocity output): V per m/s
  displacement,  ///< a displacement sensor (a laser triangulator): V per m
  microphone,    ///< a far-field microphone: pressure follows the acceleration, `delay_samples` later; V per m/s²
};

/// The kind's name in the plant file ("acceleration", "velocity", "displacement", "microphone").
std::string to_string(SensorKind kind);

/// The shape of the sensor's coloured noise.
enum class NoiseShape {
  lowpass,  ///< white noise through a first-order low-pass at `corner_hz`: flat below it, −20 dB/decade above
  pink,     ///< 1/f (−10 dB/decade) between `low_hz` and `high_hz`: a sum of first-order low-passes
};

/// Coloured noise added to the sensor's reading besides the white noise (off when rms_V is 0); seeded with it.
struct ColouredNoise {
  NoiseShape shape = NoiseShape::lowpass;
  double rms_V = 0.0;        ///< its standard deviation, volts
  double corner_hz = 10.0;   ///< lowpass: the corner
  double low_hz = 1.0;       ///< pink: the band in which the density falls as 1/f
  double high_hz = 1000.0;
};

/// The sensor and its AD converter.
struct Sensor {
  SensorKind kind = SensorKind::acceleration;
  double sensitivity_V_per_mps2 = 0.01;  ///< acceleration and microphone (the microphone's: volts per m/s² of the panel)
  double sensitivity_V_per_mps = 1.0;    ///< velocity
  double sensitivity_V_per_m = 1000.0;   ///< displacement
  double delay_samples = 0.0;  ///< microphone: the acoustic delay, samples (fractions allowed)
  double offset_V = 0.0;
  double noise_rms_V = 0.0;   ///< white Gaussian noise added to each sample
  double preamp_clip_V = 0.0; ///< > 0: the preamplifier saturates softly, v·tanh(s·a/v), before the AD filter (off: 0)
  ColouredNoise coloured_noise;
};

/// Volts per SI unit of what `sensor` reads (the sensitivity of its kind).
double sensor_sensitivity(const Sensor& sensor);

/// An eddy-current branch in the coil's circuit: L2 in parallel with R2, in series with Re and Le, so the blocked
/// impedance is Re + jωLe + jωL2·R2/(R2 + jωL2) (lossy at high frequencies). Off when L2_H is 0.
struct EddyCurrentBranch {
  double L2_H = 0.0;
  double R2_ohm = 1.0;
};

/// Everything that defines a virtual transducer.
struct PlantConfig {
  std::string name = "custom";
  double fs = 3000.0;          ///< sample rate of drive and measurements, Hz
  int oversample = 16;         ///< integrator steps per sample (RK4)
  double amplifier_gain_V = 10.0;   ///< volts at the coil per unit of drive
  double amplifier_offset_V = 0.0;  ///< DC offset of the amplifier output
  double Re_ohm = 4.0;         ///< coil resistance
  double Le_H = 3e-4;          ///< coil inductance
  EddyCurrentBranch eddy;      ///< the L2R2 branch (off unless a plant file sets it: presets do not change)
  double mass_kg = 0.05;       ///< moving mass
  double stiffness_N_per_m = 4.4e4;  ///< suspension stiffness K0
  double damping_Ns_per_m = 8.0;     ///< mechanical resistance Rm
  double Bl_Tm = 3.0;          ///< force factor Bl0
  CreepTerm creep;             ///< the suspension's creep (off unless a plant file sets it: presets do not change)
  NonlinearTerms nonlinear;
  std::vector<PanelMode> panel_modes;
  Converters converters;
  Sensor sensor;
};

/// Parses and validates a plant JSON object ("format": "panelbass.plant/1"). Unknown keys, wrong
/// types and non-physical values are ConfigErrors naming the key path; so is an integrator step too
/// coarse for the fastest dynamics (it says which oversample would do).
PlantConfig plant_from_json(const nlohmann::json& json);

/// The JSON form of `config`, every field written out.
nlohmann::json plant_to_json(const PlantConfig& config);

/// The fewest integrator steps per sample that resolve the plant's fastest linearized dynamics (plant_from_json
/// refuses fewer).
int required_oversample(const PlantConfig& config);

/// Reads a plant JSON file; ConfigError messages start with the file name.
PlantConfig load_plant_file(const std::filesystem::path& path);

/// The same plant read by a noise-free sensor: white and coloured noise off (setting noise_rms_V to 0 alone leaves
/// the coloured noise on).
PlantConfig without_sensor_noise(PlantConfig config);

/// The same plant with every nonlinear term switched off.
PlantConfig linearized(PlantConfig config);

/// The names (as in the plant file: "stiffness", "force_factor", …) of the nonlinear terms switched on, in
/// NonlinearTerms' order.
std::vector<std::string> enabled_nonlinear_terms(const PlantConfig& config);

/// The same plant with only the nonlinear term `name` left as it is and every other one off; ConfigError
/// naming the known terms for an unknown name.
PlantConfig with_only_term(PlantConfig config, const std::string& name);

}  // namespace panelbass::models

#pragma once
// The gray-box exciter model [M1]–[M3] (mirror_filter.h) fitted from the drive and the coil current alone — what a
// sound card records — as Klippel's controller does with a current sensor only: the back-EMF E_v(x)·v in the
// current carries the motion, so displacement and velocity are the model's latent states, never a column.
//
// The scale of x is unobservable from the current (x → αx with c0 → αc0, e5 → e5/α and every nonlinear coefficient
// rescaled by its power of α leaves the current, and the mirror filter, unchanged); the fit fixes it so that the
// linear model's displacement on the fitting part of the record has an rms of 1 (the model's "mm" are these units).
//   (a) Linear start (the electrical impedance's motional branch): for each resonance f0 and mechanical damping ζ of
//       a grid, the linear [M2]–[M3] is driven by the measured current (c0 = 1), and [M1] solved for the current,
//       i_{k+1} = (Σ_{j<4} a_j·drive_{k−L−j} − e5·v_{k+1})/e_R, is a linear least-squares problem in a_j/e_R and
//       e5/e_R; the lag L (−2..max_delay: the current may even lead the drive's index) and (f0, ζ) with the
//       smallest residual win. A(z) takes the DA path's filter and the fraction of a sample.
//   (b) Output error, first the linear parameters (A(z) solved by least squares in each evaluation: the linear
//       model's current is A(z) applied to that of the model without it), then with the nonlinear ones (Bl(x)'s b2
//       shared by [M1] and [M2], K(x), the friction and its velocity scale, and the inductance's slope dLe/dx as the
//       coil's magnetic energy ½·Le(x)·i² makes it act — Le(x)·di/dt, i·v·dLe/dx and the reluctance force from one
//       parameter —, and Le(i); not the inductance itself (A(z)'s), c4 nor e9; Bl(x)'s asymmetry b1 last, kept only
//       when it cuts the current's J_val by 10 %: on a symmetric Bl the current does not tell it from K(x)'s
//       asymmetry) by Levenberg–Marquardt
//       (models/optimization/levenberg_marquardt.h) on the free-run current error over the fitting part,
//       V = Σ (î − i)² / Σ i² (+ the same for the sensor, when one joins), with the Jacobian by central finite
//       differences of the free run (the friction's Newton solve and the tanh make an exact one long to write;
//       2P simulations a step are cheap at 3 kHz). A(z) is kept minimum phase (a trial outside is rejected).
//   (c) Validation: the model runs free over the whole record; J per channel on its last part (never fitted).
// An optional sensor (accelerometer, velocity, displacement or microphone) joins through
// y_k = Σ_{j<4} s_j·q_{k−D−j} with q the model's acceleration, velocity or displacement: its taps (scale, sign and
// the fraction of a sample, no assumed sensitivity) are solved inside each evaluation by least squares, its delay D
// chosen at the linear start.

#include <Eigen/Core>
#include <array>
#include <string>

#include "models/control/mirror_filter.h"

namespace panelbass::models {

/// What an optional sensor measures (a microphone's pressure is the acceleration, later).
enum class MirrorSensorKind { none, acceleration, velocity, displacement, microphone };

/// The sensor kind named `name` ("none", "acceleration", "velocity", "displacement", "microphone");
/// std::invalid_argument naming the known ones otherwise.
MirrorSensorKind mirror_sensor_kind(const std::string& name);

/// How the current-only fit runs.
struct MirrorCurrentFitOptions {
  int max_delay = 4;                ///< largest lag of the current behind the drive searched, samples (from −2)
  double validation_share = 0.3;    ///< the record's last share, never fitted, where J_val is measured
  int max_iterations = 60;          ///< Levenberg–Marquardt steps of the output-error fit
  MirrorSensorKind sensor_kind = MirrorSensorKind::none;  ///< with a sensor column, what it measures
  int max_sensor_delay = 16;        ///< largest sensor delay searched, samples (a microphone's: 64)
};

/// How the current-only fit went.
struct MirrorCurrentFit {
  MirrorModel model;                       ///< x in the fit's units (rms 1 on the record), delay = max(L, 0)
  int current_lag = 0;                     ///< L: the current's lag behind the drive, samples (may be < 0)
  double linear_j_val_pct = 0.0;           ///< the linear model's free-run current J on validation, percent
  double current_j_fit_pct = 0.0;          ///< the fitted model's free-run current J on the fitting part, percent
  double current_j_val_pct = 0.0;          ///< the same on validation, percent
  double sensor_j_val_pct = -1.0;          ///< the sensor's free-run J on validation, percent (−1: no sensor)
  std::array<double, 4> sensor_taps{};     ///< s_0..s_3 (sensor units per model unit of the kind's quantity)
  int sensor_delay = 0;                    ///< D, samples
  double resonance_hz = 0.0;               ///< the fitted linear model's resonance, √(−c6)/2π
  int iterations = 0;                      ///< Levenberg–Marquardt steps taken
  bool damping_rise = false;               ///< Rms(v)'s rise c10 kept (not negligible, it cut the current's J_val by 0.5 %)
  bool force_factor_asymmetry = false;     ///< Bl(x)'s b1 kept (it cut the current's J_val by 10 %)
};

/// Fits [M1]–[M3] to `drive` and coil `current` at `fs` (and `sensor`, empty for none, with options.sensor_kind).
/// std::invalid_argument naming the problem for columns of unequal length, fewer than 1000 samples, a non-finite
/// sample, a current that is all zero, or a sensor without its kind.
MirrorCurrentFit fit_mirror_model_from_current(const Eigen::VectorXd& drive, const Eigen::VectorXd& current, double fs,
                                               const MirrorCurrentFitOptions& options = {},
                                               const Eigen::VectorXd& sensor = Eigen::VectorXd());

/// `model` with `branch` in [M1] (r_b in `model`'s units of e_R), its drive path A(z) and [M1]'s coefficients
/// rescaled so that the linear model's current from the drive stays as it was, but for the product's taps past z⁻³
/// (dropped: A(z) keeps four): A'(z) =
/// A(z)·(1 + G_b(z)/e_R)/(1 + g/e_R), G_b(z) = g·(1 − z⁻¹)/(1 − p·z⁻¹) the branch's voltage per current, g and p its
/// step (eddy_step). Only the back-EMF's path then changes: the start of a refit with the branch.
MirrorModel add_eddy_branch(const MirrorModel& model, const MirrorEddyBranch& branch);

/// The fit continued from `from` (a model fit_mirror_model_from_current made, its current `lag` samples behind the
/// drive) on the same record, with its eddy-current branch held as `from` has it (none, or one put there to try) and
/// every other coefficient the fit fits refitted by output error from where `from` has it — Rms(v)'s rise and Bl(x)'s
/// asymmetry only where `from` has them —, options.max_iterations steps at most; no sensor. std::invalid_argument for a
/// record the fit would refuse or a model that runs away on it.
MirrorCurrentFit refit_mirror_model_from_current(const Eigen::VectorXd& drive, const Eigen::VectorXd& current, double fs,
                                                 const MirrorModel& from, int lag, const MirrorCurrentFitOptions& options = {});

/// The same model with its displacement in units α times as large (x' = α·x): the current, and the mirror filter,
/// are unchanged.
MirrorModel rescale_displacement(const MirrorModel& model, double alpha);

}  // namespace panelbass::models

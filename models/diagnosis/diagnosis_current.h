#pragma once
// Diagnosis, every channel the record has: the coil current. As Klippel's LSI does, the measured current is the
// force's input — the mechanics feel Bl·i whatever the electrical loop did — so the acceleration explained from
// the current (an OE model i → y, the force channel) leaves only what a force of the motion adds: K(x), Rms(v),
// friction, Bl(x)·i. The voltage-side effects (Le(x, i), the back-EMF Bl(x)·v, Re(T), the amplifier) are
// absorbed by the measured current and vanish from it. Effects that look alike in the drive-to-output residual
// (near one resonance v³ and x³ differ by a phase; a coil offset's x·u and a spring's x²) are told apart there,
// with features on the measured current and no leads to absorb a phase. Folder-internal (namespace
// diagnosis_detail), used by the driver (diagnosis.cpp).

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis_fit.h"

namespace panelbass::models::diagnosis_detail {

/// The force channel of a record with the current: the output explained from the measured current.
struct ForceChannel {
  LinearModel path;                     ///< OE from the current to the output (raw units in and out)
  const Eigen::VectorXd* i_est = nullptr;  ///< the measured current, estimation and validation records
  const Eigen::VectorXd* i_val = nullptr;
  Eigen::VectorXd residual_est, residual_val;  ///< y − path·i, in the path's scaled output units
  double y_energy_val = 0.0;            ///< Σ y² of the scaled validation output after init (J's denominator)
  double j_val_pct = 0.0;               ///< the path's validation J (what the force channel leaves)
};

/// The force channel from the path `path` (identified on the current of `i_est`, judged on `i_val`).
ForceChannel force_channel(const Records& r, const LinearModel& path, const Eigen::VectorXd& i_est,
                           const Eigen::VectorXd& i_val);

/// Whether `effect` acts as a force of the motion (its force-channel features exist): the springs, the
/// damping, friction and the force factor; inductance's reluctance force ½·i²·dLe/dx counts too.
bool acts_as_force(Effect effect);

/// Whether `a` and `b` look alike in the drive-to-output residual (a known pair that only another channel
/// separates): nonlinear_damping with cubic_stiffness, hysteresis or force_factor; asymmetric_force_factor
/// with asymmetric_stiffness or inductance; and creep with resonance or antiresonance — all three linear, which
/// no channel separates once the force channel's own linear path absorbs them (the drive's margin decides).
bool look_alike(Effect a, Effect b);

/// The force channel's verdict on one effect: the BIC of its features on the channel's validation residual
/// (N·ln(J_before/J_after) − p·ln N, N its samples), with the features of `kept` (earlier findings) in both.
struct ForceScore {
  double score = 0.0;
  double j_before_pct = 0.0, j_after_pct = 0.0;
  int parameters = 0;
};

/// The force-channel score of `effect` given the findings `kept`; the states (x, v) are those of the channel's path
/// simulated from the measured current (from rest, in `current`'s output scaling), the displacement's proxy chosen
/// by `r.output` (unknown: an accelerometer's).
ForceScore force_score(const ForceChannel& channel, const Records& r, const Fit& current, Effect effect,
                       const std::vector<Effect>& kept);

}  // namespace panelbass::models::diagnosis_detail

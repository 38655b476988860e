#include "models/diagnosis/diagnosis_explanations.h"
#include "models/diagnosis/gray_box_model.h"

#include <cmath>
#include <vector>

namespace panelbass::models::diagnosis_detail {

double added_correlation(const Records& r, const Fit& before, const Fit& after) {
  const Eigen::VectorXd y0 = simulate_augmented(before.model, r.u_est, r.y_est, r.init);
  const Eigen::VectorXd y1 = simulate_augmented(after.model, r.u_est, r.y_est, r.init);
  const Eigen::Index n = y0.size() - r.init;
  const Eigen::VectorXd e = (r.y_est - y0).tail(n), d = (y1 - y0).tail(n);
  const double norm = e.norm() * d.norm();
  return norm > 0.0 ? e.dot(d) / norm : 0.0;
}

namespace {

// The residual's rms at high over low input level counts as a difference outside [1/this, this].
constexpr double kLevelRatioShown = 1.2;

bool acts_on_displacement(Effect e) {
  return e == Effect::cubic_stiffness || e == Effect::asymmetric_stiffness || e == Effect::force_factor ||
         e == Effect::asymmetric_force_factor || e == Effect::creep;
}

// The physical quantity a state proxy estimates, for the sensors the plant may have (this project's transducer
// measures acceleration); a term of a force acting on displacement says when its proxy only stands in for it.
std::string state_quantity(const std::string& state, bool on_displacement) {
  if (state == "output") return "output (the displacement for a displacement sensor)";
  if (state == "integral") {
    return on_displacement ? "integral of the output (the displacement for a velocity sensor; for an accelerometer a "
                             "velocity, standing in for the displacement the force acts on)"
                           : "integral of the output (the velocity, for an accelerometer)";
  }
  if (state == "double_integral") return "double integral of the output (the displacement, for an accelerometer)";
  return state;
}

// ", and is 2.3 times larger at high input level than at low" when the level matters; nothing when it is ~1.
std::string level_clause(double ratio) {
  if (!(ratio > kLevelRatioShown)) return "";
  return ", and is " + fixed(ratio, 1) + " times larger at high input level than at low";
}

}  // namespace

std::string explain(const Candidate& c, const ResidualLocation& where, double correlation) {
  const std::string state =
      state_quantity(c.parameters_json.contains("state") ? c.parameters_json["state"].get<std::string>() : "",
                     acts_on_displacement(c.effect));
  const std::string r = fixed(correlation, 2);
  switch (c.effect) {
    case Effect::dc_offset:
      return "The model leaves out a DC offset in the drive or the sensor: the residual mean is " + fixed(where.mean, 4) +
             ", " + fixed(std::abs(where.mean_t), 1) + " standard errors from zero.";
    case Effect::delay:
      return "The model leaves out " + std::string(c.parameters_json["nk_after"].get<int>() > c.parameters_json["nk_before"].get<int>() ? "a sample more" : "a sample less") +
             " of dead time: the whole response is misaligned (shifting the simulated output by one sample changes J by " +
             fixed(c.parameters_json["shift_j_pct"].get<double>(), 2) + " %), and refitting with nk = " +
             std::to_string(c.parameters_json["nk_after"].get<int>()) + " lowers J by " +
             fixed(c.parameters_json["j_recovered_pct"].get<double>(), 2) + " %.";
    case Effect::resonance:
      return "The model leaves out a lightly damped mode near " + fixed(c.parameters_json["frequency_hz"].get<double>(), 0) +
             " Hz: the residual spectrum peaks at " + fixed(where.peak_frequency_hz, 0) + " Hz (" +
             fixed(where.peak_over_noise, 2) + " times the noise floor), and an extra pole pair there, adding motion in "
             "quadrature with the response (" + fixed(c.parameters_json["change_phase_deg"].get<double>(), 0) + "°), explains it.";
    case Effect::antiresonance:
      return "The model leaves out an antiresonance near " + fixed(c.parameters_json["frequency_hz"].get<double>(), 0) +
             " Hz (modes cancelling): the model over-predicts there by " +
             fixed(c.parameters_json["dip_db"].get<double>(), 2) + " dB, the residual spectrum peaks at " +
             fixed(where.peak_frequency_hz, 0) + " Hz, and a zero pair with its pole pair fills the dip.";
    case Effect::cubic_stiffness:
      return "The model leaves out a cubic stiffness (a spring that hardens or softens with excursion): the residual "
             "follows the cube of the estimated " + state + " (odd and level-dependent; correlation " + r + ").";
    case Effect::asymmetric_stiffness:
      return "The model leaves out an asymmetric stiffness: the residual follows the square of the estimated " + state +
             " (even-order; correlation " + r + ").";
    case Effect::hysteresis:
      return "The model leaves out friction or hysteresis: the residual follows the direction of motion of the estimated " +
             state + " rather than its position (correlation " + r + ").";
    case Effect::saturation:
      return std::string(c.parameters_json["one_sided"].get<bool>()
                             ? "The model leaves out a saturation that differs between the two directions (diode-like): "
                             : "The model leaves out a saturation (clipping) alike in both directions: ") +
             (c.parameters_json.value("structure", "") == "Hammerstein behind the drive's filter"
                  ? "the residual follows the input, through a filter of the drive (" +
                        std::to_string(c.parameters_json.value("front_order", 0)) +
                        (c.parameters_json.value("front_order", 0) == 1 ? " pole" : " poles") +
                        " before the clip, well damped and above the lowest resonance: a converter's or "
                        "amplifier's; the resonances after it), beyond "
                  : std::string("the residual follows the input beyond ")) +
             fixed(c.parameters_json["knee_fraction_of_peak"].get<double>() * 100.0, 0) + " % of its peak" +
             level_clause(where.level_ratio) + ".";
    case Effect::force_factor:
      return "The model leaves out a force factor that falls with excursion (the coil leaving the gap): the residual "
             "follows the drive times the square of the estimated " + state + " (odd, intermodulating; correlation " + r + ").";
    case Effect::inductance:
      return std::string("The model leaves out an inductance that varies with ") +
             (c.parameters_json["state"] == "input" ? "the current" : "excursion") +
             ": the residual follows the estimated " + (c.parameters_json["state"] == "input" ? std::string("drive") : state) +
             " times the rate of change of the drive (an i·di/dt-type term, strongest above resonance; correlation " + r + ").";
    case Effect::thermal_compression:
      return "The model leaves out thermal compression (the coil resistance rising with dissipated power): the residual "
             "follows the drive times its power averaged over " + fixed(c.parameters_json["time_constant_s"].get<double>(), 1) +
             " s (the gain changed by " + fixed(where.gain_drift * 100.0, 2) + " % between the first and the last quarter; correlation " + r + ").";
    case Effect::asymmetric_force_factor:
      return "The model leaves out a force factor that differs on the two sides of the rest position (a coil offset, "
             "Bl(x) with an odd term): the residual follows the drive times the estimated " + state +
             " (even harmonics and a DC displacement; correlation " + r + ").";
    case Effect::nonlinear_damping:
      return "The model leaves out a mechanical resistance that rises with velocity (nonlinear damping, Rms(v)): the "
             "residual follows the cube of the rate of change of the estimated " + state +
             " (odd, strongest at resonance where the velocity peaks; correlation " + r + ").";
    case Effect::creep:
      return "The model leaves out creep of the suspension (a viscoelastic spring that relaxes over " +
             fixed(c.parameters_json["time_constant_s"].get<double>() * 1000.0, 0) +
             " ms): the residual follows the estimated " + state + " averaged over that time, a softer spring far below "
             "the resonance where the displacement rises (linear: no harmonics; correlation " + r + ").";
    case Effect::static_nonlinearity: {
      const nlohmann::json& p = c.parameters_json;
      const bool wiener = p.value("position", "") == "output";
      const std::string shape = p.value("shape", "");
      const std::string what = shape == "polynomial" ? "a polynomial of order " + std::to_string(p.value("polynomial_order", 3))
                               : shape == "saturating" ? std::string("a saturating knee")
                               : shape == "dead zone" ? std::string("a knee past which the gain rises (dead-zone-like)")
                                                      : "a knee (" + shape + ")";
      return "The model leaves out a static nonlinearity, " + what +
             (shape == "polynomial" ? std::string("") : p.value("one_sided", false) ? ", different on the two sides," : ", alike on both sides,") +
             (wiener ? " at the output of the dynamics (a Wiener structure)"
                     : " between two filters (a Wiener–Hammerstein structure: " + std::to_string(p.value("front_order", 0)) +
                           " poles before it, " + std::to_string(p.value("back_order", 0)) + " and the zeros after)") +
             ": the residual follows a static function of the input filtered by the first part of the dynamics (correlation " + r + ")" +
             level_clause(where.level_ratio) + ".";
    }
    default: return "The model leaves out " + to_string(c.effect) + ".";
  }
}

nlohmann::json terms_json(const AugmentedModel& m) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& t : m.terms) out.push_back(term_to_json(t));
  return out;
}

}  // namespace panelbass::models::diagnosis_detail

#include "tests/support/diagnosis_scenarios.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dsp/excitation.h"
#include "dsp/spectrum.h"
#include "models/linear/linear_identification.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::models {
namespace {

// Seconds between changes of the drive level in a level-modulated record, and the quiet level.
constexpr double kLevelPeriodS = 3.0;
constexpr double kQuietLevel = 0.3;

// Stiffness, force factor and inductance coefficients of the panel exciter (plant_presets.cpp), each
// switched on alone at `scale` of its strength.
PlantConfig with_stiffness(PlantConfig p, double k1, double k2, double scale) {
  p.nonlinear.stiffness = {};
  p.nonlinear.stiffness.enabled = true;
  p.nonlinear.stiffness.k1_per_mm = k1;
  p.nonlinear.stiffness.k2_per_mm2 = k2;
  p.nonlinear.stiffness.scale = scale;
  return p;
}

// The second family's sizes relative to the first's: each effect's concealment ratio on the second family's plant
// brought near the first's (the ratio grows as the size squared), from `diagnosis_detection_bench
// --concealment-only` on both families.
double second_family_size(Effect effect) {
  switch (effect) {
    case Effect::resonance: return 1.22;
    case Effect::antiresonance: return 1.29;
    case Effect::delay: return 1.0;  // a structure, not a size
    case Effect::cubic_stiffness: return 2.21;
    case Effect::asymmetric_stiffness: return 1.67;
    case Effect::force_factor: return 2.16;
    case Effect::inductance: return 2.25;
    case Effect::hysteresis: return 1.36;
    case Effect::saturation: return 4.0;
    case Effect::thermal_compression: return 2.42;
    case Effect::dc_offset: return 5.7;  // the pink noise is strongest near DC
    case Effect::static_nonlinearity: return 1.8;
    case Effect::nonlinear_damping: return 4.36;
    case Effect::asymmetric_force_factor: return 1.9;
    case Effect::creep: return 0.86;
  }
  return 1.0;
}

}  // namespace

std::string to_string(PlantFamily family) { return family == PlantFamily::second ? "second" : "panel"; }

PlantFamily plant_family_named(const std::string& name) {
  if (name == "panel") return PlantFamily::panel;
  if (name == "second") return PlantFamily::second;
  throw std::invalid_argument("unknown plant family \"" + name + "\" (families: panel, second)");
}

PlantConfig family_base(PlantFamily family) {
  if (family == PlantFamily::panel) return plant_preset("linear");
  PlantConfig p = load_plant_file(std::string(PANELBASS_SOURCE_DIR) + "/tests/support/plants/second-exciter-linear.json");
  p.creep = {};  // creep is one of the effects
  return p;
}

int family_order(PlantFamily family) { return family == PlantFamily::panel ? 13 : 16; }

int family_delay(PlantFamily family) { return family_base(family).converters.delay_samples; }

DiagnosisScenario plain_scenario(PlantFamily family) {
  return {"none", {}, family_base(family), false, ScenarioBaseline::identified, family};
}

std::vector<DiagnosisScenario> effect_free_scenarios(PlantFamily family) {
  std::vector<DiagnosisScenario> out{plain_scenario(family)};
  if (family == PlantFamily::second) {
    DiagnosisScenario mic = plain_scenario(family);
    mic.name = "none-microphone";
    mic.plant.sensor.kind = SensorKind::microphone;
    mic.plant.sensor.sensitivity_V_per_mps2 = 0.002;
    mic.plant.sensor.delay_samples = 3.4;
    out.push_back(mic);
  }
  return out;
}

DiagnosisScenario concealed_scenario(Effect effect, double size, PlantFamily family) {
  if (!(size > 0.0) || !std::isfinite(size))
    throw std::invalid_argument("concealed_scenario: size " + std::to_string(size) + " is not a positive number");
  if (family == PlantFamily::second) size *= second_family_size(effect);
  DiagnosisScenario s = plain_scenario(family);
  s.name = to_string(effect);
  s.effects = {effect};
  PlantConfig& p = s.plant;
  switch (effect) {
    case Effect::cubic_stiffness: p = with_stiffness(p, 0.0, 0.06, 0.026 * size); break;
    case Effect::asymmetric_stiffness: p = with_stiffness(p, 0.03, 0.0, 0.3 * size); break;
    case Effect::force_factor:
      p.nonlinear.force_factor.enabled = true;
      p.nonlinear.force_factor.b1_per_mm = 0.0;
      p.nonlinear.force_factor.b2_per_mm2 = -0.45;
      p.nonlinear.force_factor.scale = 0.034 * size;
      break;
    case Effect::asymmetric_force_factor:  // a coil offset: Bl(x) = Bl₀(1 + b₁x)
      p.nonlinear.force_factor.enabled = true;
      p.nonlinear.force_factor.b1_per_mm = -0.3;
      p.nonlinear.force_factor.b2_per_mm2 = 0.0;
      p.nonlinear.force_factor.scale = 0.045 * size;
      break;
    case Effect::inductance:
      p.nonlinear.inductance.enabled = true;
      p.nonlinear.inductance.l1_per_mm = -0.1;
      p.nonlinear.inductance.l2_per_mm2 = 0.0;
      p.nonlinear.inductance.li2_per_A2 = -0.02;
      p.nonlinear.inductance.scale = 0.36 * size;
      break;
    case Effect::hysteresis:
      p.nonlinear.friction.enabled = true;
      p.nonlinear.friction.coulomb_N = 0.05;
      p.nonlinear.friction.scale = 0.4 * size;
      break;
    case Effect::saturation:
      p.nonlinear.clipping.enabled = true;
      p.nonlinear.clipping.level = 1.0 - 0.032 * size;
      p.nonlinear.clipping.knee = 0.02;
      break;
    case Effect::static_nonlinearity:  // the sensor's preamplifier saturates between the mechanics and the AD filter
      p.sensor.preamp_clip_V = 8.0 / size;
      break;
    case Effect::nonlinear_damping:  // Rms(v) = Rm·(1 + r2·v²)
      p.nonlinear.damping.enabled = true;
      p.nonlinear.damping.r2_per_m2ps2 = 1.0;
      p.nonlinear.damping.scale = 0.06 * size;
      break;
    case Effect::creep:  // the suspension relaxes by 0.7 % of its stiffness over 10 ms (4 %: visible, ratio 14)
      p.creep.fraction = 0.007 * size;
      p.creep.time_constant_s = 0.01;
      s.baseline = ScenarioBaseline::given_reference;
      break;
    case Effect::thermal_compression:
      p.nonlinear.thermal.enabled = true;
      p.nonlinear.thermal.scale = 0.05 * size;
      s.modulated_level = true;
      break;
    case Effect::dc_offset:
      p.sensor.offset_V = 0.0035 * size;
      s.baseline = ScenarioBaseline::given_reference;
      break;
    case Effect::delay:
      // The converters smear the drive: the sample before the first visible one is small. A baseline with
      // the delay estimated from the data starts one sample late. (`size` does not apply.)
      s.baseline = ScenarioBaseline::given_visible;
      p.converters.da_filter.cutoff_hz += 750.0 * size;
      break;
    case Effect::resonance:  // a lightly damped panel mode the baseline's order has no room for
      p.panel_modes.push_back({450.0, 0.01, 0.0018 * size});
      s.baseline = ScenarioBaseline::given_reference;
      break;
    case Effect::antiresonance:  // two modes of opposite sign close together: between them they oppose the response
      p.panel_modes.push_back({440.0, 0.05, -0.0098 * size});
      p.panel_modes.push_back({460.0, 0.05, 0.0098 * size});
      s.baseline = ScenarioBaseline::given_reference;
      break;
  }
  return s;
}

DiagnosisScenario combined_scenario(const DiagnosisScenario& first, const DiagnosisScenario& second) {
  DiagnosisScenario s = first;
  s.name = first.name + "+" + second.name;
  s.effects.insert(s.effects.end(), second.effects.begin(), second.effects.end());
  const PlantConfig plain = plain_scenario(first.family).plant;
  // Every part of the plant the second scenario changed.
  PlantConfig& p = s.plant;
  const PlantConfig& q = second.plant;
  if (q.nonlinear.stiffness.enabled) p.nonlinear.stiffness = q.nonlinear.stiffness;
  if (q.nonlinear.force_factor.enabled) p.nonlinear.force_factor = q.nonlinear.force_factor;
  if (q.nonlinear.inductance.enabled) p.nonlinear.inductance = q.nonlinear.inductance;
  if (q.nonlinear.friction.enabled) p.nonlinear.friction = q.nonlinear.friction;
  if (q.nonlinear.clipping.enabled) p.nonlinear.clipping = q.nonlinear.clipping;
  if (q.nonlinear.thermal.enabled) p.nonlinear.thermal = q.nonlinear.thermal;
  if (q.nonlinear.damping.enabled) p.nonlinear.damping = q.nonlinear.damping;
  if (q.creep.fraction != plain.creep.fraction) p.creep = q.creep;
  if (q.sensor.offset_V != plain.sensor.offset_V) p.sensor.offset_V = q.sensor.offset_V;
  if (q.sensor.preamp_clip_V != plain.sensor.preamp_clip_V) p.sensor.preamp_clip_V = q.sensor.preamp_clip_V;
  for (std::size_t k = plain.panel_modes.size(); k < q.panel_modes.size(); ++k) p.panel_modes.push_back(q.panel_modes[k]);
  s.modulated_level = first.modulated_level || second.modulated_level;
  if (s.baseline == ScenarioBaseline::identified) s.baseline = second.baseline;
  return s;
}

ScenarioRecords scenario_records(const DiagnosisScenario& scenario, std::uint64_t seed, Eigen::Index n_est,
                                 Eigen::Index n_val) {
  if (n_est <= 0 || n_val <= 0) throw std::invalid_argument("scenario_records: record lengths must be positive");
  const Eigen::Index n = n_est + n_val;
  Eigen::VectorXd u = dsp::uniform_noise(static_cast<std::size_t>(n), 1.0, seed);
  if (scenario.modulated_level) {
    // Blocks of kLevelPeriodS seconds, each loud (1) or quiet (kQuietLevel) at random: the coil heats and cools.
    const auto block = static_cast<Eigen::Index>(kLevelPeriodS * scenario.plant.fs);
    const Eigen::VectorXd pick = dsp::uniform_noise(static_cast<std::size_t>(n / block + 1), 1.0, seed + 7);
    for (Eigen::Index k = 0; k < n; ++k) u[k] *= pick[k / block] > 0.0 ? 1.0 : kQuietLevel;
  }
  const PlantRecord record = simulate(scenario.plant, u, seed + 100);
  const Eigen::VectorXd y_clean = simulate(without_sensor_noise(scenario.plant), u, seed + 100).y;
  return {u.head(n_est),           record.y.head(n_est),    u.tail(n_val),        record.y.tail(n_val),
          y_clean.tail(n_val),     record.i.head(n_est),    record.i.tail(n_val), scenario.plant.fs};
}

std::optional<LinearModel> scenario_baseline(const DiagnosisScenario& scenario) {
  if (scenario.baseline == ScenarioBaseline::identified) return std::nullopt;
  // Identified from seed 50 on the plant without the effect, true order and delay (given_reference: the
  // model a user made before the sensor drifted or the exciter was glued to another panel), or on the
  // scenario's own plant with the delay the data shows (given_visible).
  DiagnosisScenario before = plain_scenario(scenario.family);
  if (scenario.baseline == ScenarioBaseline::given_visible) before.plant = scenario.plant;
  const ScenarioRecords r = scenario_records(before, 50, 20000, 5000);
  LinearIdentificationSpec spec;
  spec.method = LinearMethod::oe;
  spec.order = family_order(scenario.family);  // the true structure (see linear_identification_test.cpp)
  if (scenario.baseline == ScenarioBaseline::given_reference) spec.delay = family_delay(scenario.family);
  spec.fs = r.fs;
  return identify_linear(r.u_est, r.y_est, r.u_val, r.y_val, spec).model;
}

double concealment_ratio(const ScenarioRecords& r, const LinearModel& baseline, Eigen::Index init) {
  const Eigen::VectorXd missed = r.y_val_clean - baseline.simulate(r.u_val, r.y_val_clean, init);
  const Eigen::VectorXd noise = r.y_val - r.y_val_clean;
  const Eigen::Index n = r.u_val.size() - init;
  const dsp::WelchSpec spec{512, 0.5, dsp::Window::hann};
  const dsp::PowerSpectrum effect = dsp::welch_psd(missed.tail(n), r.fs, spec);
  const dsp::PowerSpectrum sensor = dsp::welch_psd(noise.tail(n), r.fs, spec);
  double worst = 0.0;
  for (Eigen::Index k = 0; k < effect.psd.size(); ++k) worst = std::max(worst, effect.psd[k] / sensor.psd[k]);
  return worst;
}

}  // namespace panelbass::models

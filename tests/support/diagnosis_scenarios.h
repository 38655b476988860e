#pragma once
// Diagnosis scenarios: the `linear` virtual transducer with one or more effects of the diagnosis
// vocabulary switched on, small enough to be concealed (what the baseline misses lies below the sensor
// noise in the raw residual spectrum) yet large enough to be found from a long record. Shared by the
// tests, which assert that each effect is named, and the detection-rate benchmark, which scales them.

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis_terms.h"
#include "models/linear/linear_model.h"
#include "models/plant/plant_config.h"

namespace panelbass::models {

/// Which transducers the scenarios are built on.
enum class PlantFamily {
  panel,   ///< the `linear` preset (panel-exciter's values and structure): the structure the candidate terms mirror
  second,  ///< tests/support/plants/second-exciter-linear.json without its creep: other values, an L2R2 branch, a
           ///< second panel mode, other converters (DA 2nd order, AD 6th), pink sensor noise (issue 58's second family)
};

/// The family's name ("panel", "second").
std::string to_string(PlantFamily family);

/// The family named `name`; std::invalid_argument naming the families otherwise.
PlantFamily plant_family_named(const std::string& name);

/// The family's plant without any effect (every nonlinear term off, no creep).
PlantConfig family_base(PlantFamily family);

/// The order of the family's linear plant (its states: coil, L2R2, mechanics, panel modes, converter filters).
int family_order(PlantFamily family);

/// The family's converter delay, samples (what a reference baseline is given).
int family_delay(PlantFamily family);

/// How the baseline of a scenario is obtained.
enum class ScenarioBaseline {
  identified,      ///< diagnose identifies its own best linear model
  given_reference, ///< a model identified on the plant without the effect, seed 50 (true order, true delay)
  given_visible,   ///< the same with the delay estimated from the data (the first visible sample)
};

/// One scenario: the plant, its excitation and the baseline the diagnosis starts from.
struct DiagnosisScenario {
  std::string name;
  std::vector<Effect> effects;   ///< what was switched on (empty: none)
  PlantConfig plant;
  bool modulated_level = false;  ///< the drive level changes every few seconds (a program, not steady noise)
  ScenarioBaseline baseline = ScenarioBaseline::identified;
  PlantFamily family = PlantFamily::panel;
};

/// The scenario for `effect` at `size` times its concealed size (1 = the size the tests use) on `family`'s plant
/// (the second family's sizes are scaled so that each effect is about as concealed as on the first).
/// Throws std::invalid_argument for a size that is not positive.
DiagnosisScenario concealed_scenario(Effect effect, double size = 1.0, PlantFamily family = PlantFamily::panel);

/// The scenario with no effect at all (for false positives).
DiagnosisScenario plain_scenario(PlantFamily family = PlantFamily::panel);

/// The family's effect-free scenarios: the plain one, and for the second family also the same plant read by a
/// microphone 3.4 samples behind ("none-microphone").
std::vector<DiagnosisScenario> effect_free_scenarios(PlantFamily family);

/// The two scenarios' effects at once (plant changes of both applied; baseline and level of the first
/// unless the second needs its own).
DiagnosisScenario combined_scenario(const DiagnosisScenario& first, const DiagnosisScenario& second);

/// Records of a scenario: estimation and validation parts of one long run.
struct ScenarioRecords {
  Eigen::VectorXd u_est, y_est, u_val, y_val;
  Eigen::VectorXd y_val_clean;  ///< the validation output without sensor noise
  Eigen::VectorXd i_est, i_val;  ///< the coil current (A), as the virtual transducer writes it
  double fs = 0.0;
};

/// Drives the scenario's plant with uniform noise at full scale (level-modulated if the scenario says
/// so) from `seed`, n_est + n_val samples, and splits the record.
ScenarioRecords scenario_records(const DiagnosisScenario& scenario, std::uint64_t seed, Eigen::Index n_est,
                                 Eigen::Index n_val);

/// The baseline a scenario gives the diagnosis (nothing when it identifies its own).
std::optional<LinearModel> scenario_baseline(const DiagnosisScenario& scenario);

/// Largest ratio, over the bins of a Welch spectrum (512-sample Hann segments, DC included), of the PSD
/// of what `baseline` misses on the noise-free validation output to the PSD of the sensor noise; below 1
/// the effect is concealed in the raw residual spectrum.
double concealment_ratio(const ScenarioRecords& records, const LinearModel& baseline, Eigen::Index init);

}  // namespace panelbass::models

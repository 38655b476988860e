#pragma once
// Diagnosis (issue #9): where a linear simulation and a recording disagree, which physics the model
// leaves out, that physics added to the model, and validation J before and after each step.

#include <Eigen/Core>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis_locate.h"
#include "models/diagnosis/diagnosis_terms.h"
#include "models/linear/linear_model.h"

namespace panelbass::models {

/// How close to the noise floor a final validation J counts as there: within 10 %, what the floor's own
/// estimate (a median of the residual's top band) is good to.
inline constexpr double kNoiseFloorMargin = 1.1;

/// Whether validation J `j_pct` is at the noise floor `noise_floor_pct` (J < kNoiseFloorMargin × floor, floor > 0):
/// what is left of the residual is noise.
bool at_noise_floor(double j_pct, double noise_floor_pct);

/// What the recorded output measures, when known: it says which state proxy is the displacement (the output,
/// its integral, its double integral), so that a force of the displacement (a spring, the force factor) and one
/// of the velocity (damping) are not the same cube of the same signal.
enum class OutputQuantity { unknown, displacement, velocity, acceleration };

/// The quantity's name ("unknown", "displacement", "velocity", "acceleration").
std::string to_string(OutputQuantity quantity);

/// Every quantity, in the order of the enum (for the CLI's and the API's choices).
std::vector<OutputQuantity> all_output_quantities();

/// A record at another drive level than the one diagnosed (its validation part): each finding is judged there too.
struct LevelRecord {
  std::string name;     ///< as the report names it (a file, a record id)
  Eigen::VectorXd u, y; ///< input and output, raw units, at the diagnosis's rate
};

/// How a diagnosis runs.
struct DiagnosisOptions {
  OutputQuantity output = OutputQuantity::unknown;  ///< known: mechanical terms act on the displacement proxy only
  Eigen::Index init = 50;   ///< measured outputs that set a simulation's state; J counts the samples after them
  int scan_from = 2;        ///< without a baseline: OE orders scanned for the best linear model
  int scan_to = 14;
  int lags = 2;             ///< delays (0..lags−1) of each gray-box term through the baseline's dynamics, besides kTermLead leads
  int max_findings = 4;     ///< augmentation rounds at most
  int oe_iterations = 30;   ///< Levenberg–Marquardt iterations of a refit (delay, resonance)
  std::function<void(const std::string& stage)> progress;  ///< told what is being done
  /// The coil current of the estimation and validation records, when the record carries it (both empty: it
  /// does not). It is the force channel's input: it tells apart the effects that look alike from the drive.
  Eigen::VectorXd current_est, current_val;
  /// Records at other levels (empty: one level): a finding whose gain in J grows with the level is nonlinear, one
  /// whose gain does not is a linear mismatch; a finding whose growth contradicts its effect is called ambiguous.
  std::vector<LevelRecord> other_levels;
  std::string level_name = "validation";  ///< the diagnosed validation record's name among the levels
};

/// One augmentation kept: the physics, why, and what it did to validation J.
struct Finding {
  Effect effect = Effect::dc_offset;
  std::string explanation;      ///< one plain sentence: the physics left out and the evidence
  nlohmann::json evidence = nlohmann::json::object();
  nlohmann::json parameters = nlohmann::json::object();
  int added_parameters = 0;
  double j_val_before_pct = 0.0;
  double j_val_after_pct = 0.0;
  nlohmann::json confidence = nlohmann::json::object();  ///< runner-up, BIC margin, "clear"/"likely"/"ambiguous"
};

/// A free-run simulation on raw data (the first `init` measured outputs `y` may set its state).
using RecordSimulation =
    std::function<Eigen::VectorXd(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init)>;

/// A simulation to diagnose that is not a linear model: a NARX model or a virtual-transducer plant.
struct SimulationBaseline {
  std::string kind;             ///< "narx", "ss" or "plant", as reported
  double fs = 0.0;              ///< its sample rate, Hz
  RecordSimulation simulate;    ///< raw units in and out
};

/// The augmented model a diagnosis ends with: the (possibly refitted) linear part and the gray-box terms.
/// With a baseline that is not linear, the output is that simulation plus the change a refit made to the
/// linear part (`linear` − `reference`, both simulated from rest), plus the terms.
struct AugmentedModel {
  LinearModel linear;       ///< the linear baseline, or the linearisation of a simulation baseline (maybe refitted)
  LinearModel reference;    ///< with simulate_baseline: the linearisation `linear` started from
  RecordSimulation simulate_baseline;  ///< empty for a linear baseline
  std::vector<DiagnosisTerm> terms;
  int lags = 3;                                          ///< delays of each term (see DiagnosisOptions)
  Eigen::Vector4d state_mean = Eigen::Vector4d::Zero();  ///< state-proxy normalisation from the estimation record
  Eigen::Vector4d state_rms = Eigen::Vector4d::Ones();
};

/// The result of a diagnosis.
struct Diagnosis {
  std::string baseline_kind = "linear";
  std::vector<std::string> channels{"drive", "output"};  ///< the record's channels the diagnosis used
  nlohmann::json current_channel;           ///< with the current: the force channel's path and J (null without)
  OutputQuantity output_quantity = OutputQuantity::unknown;  ///< what the output measures, as told
  nlohmann::json baseline_info = nlohmann::json::object();  ///< method, orders, how it was chosen
  double baseline_j_val_pct = 0.0;
  double baseline_j_est_pct = 0.0;
  std::vector<Finding> findings;            ///< in the order applied; empty when nothing significant is left
  double j_val_before_pct = 0.0;
  double j_val_after_pct = 0.0;
  double noise_floor_pct = 0.0;             ///< J of a model that left only noise (see noise_floor's source)
  nlohmann::json noise_floor;               ///< the floor, its uncertainty, its source and the estimates it was chosen from
  nlohmann::json stop;                      ///< why the rounds stopped (null: after max_findings)
  bool at_noise_floor = false;              ///< at_noise_floor(j_val_after_pct, noise_floor_pct): nothing but noise is left
  nlohmann::json unexplained;               ///< what is left above the floor and where (null at the floor)
  ResidualLocation located_est, located_val;  ///< the baseline's residual
  ResidualLocation located_val_after;         ///< the final model's validation residual
  nlohmann::json rounds = nlohmann::json::array();  ///< per round: every candidate's best variant and its score
  AugmentedModel model;     ///< the final model
  AugmentedModel baseline_model;  ///< the simulation diagnosed, as a model without terms (.linear: the linear model, or a simulation's linearisation)
};

/// Diagnoses `baseline` (or, without one, the best linear OE model over the order scan of `options`) on
/// estimation and validation records at rate `fs`: locates the residual, scores the candidate effects
/// by fitting each augmentation on the estimation record and judging it on the validation record, and
/// keeps the best while N·ln(J_before/J_after) > p·ln(N) on the N validation samples (a BIC rule, p the
/// parameters added). Throws std::invalid_argument for unusable records (naming which and why).
Diagnosis diagnose(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val,
                   const Eigen::VectorXd& y_val, double fs, const std::optional<LinearModel>& baseline,
                   const DiagnosisOptions& options = {});

/// Diagnoses a simulation that is not a linear model (a NARX model, a virtual-transducer plant): the
/// gray-box terms act through the dynamics of its linearisation (the best OE model of its own output over
/// the order scan of `options`), and a linear refit adds its change to the simulation. Throws
/// std::invalid_argument as the linear form does, and for a simulation that is not finite or at another rate.
Diagnosis diagnose(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val,
                   const Eigen::VectorXd& y_val, double fs, const SimulationBaseline& baseline,
                   const DiagnosisOptions& options = {});

/// Simulates `model` on raw data, state set by the first `init` measured outputs (raw units out).
Eigen::VectorXd simulate_augmented(const AugmentedModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                   Eigen::Index init);

/// The report: {"baseline":{"kind","J_val_pct",…},"findings":[…],"J_val_before_pct","J_val_after_pct",
/// "noise_floor_pct","at_noise_floor","location":{…}}.
nlohmann::json diagnosis_to_json(const Diagnosis& diagnosis);

}  // namespace panelbass::models

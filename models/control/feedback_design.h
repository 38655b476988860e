#pragma once
// Designing the neural feedback controller on the models (fig. 7.10): the training records (the program
// through band-pass and LQ feedforward, and the desired response [7B] y_lin), then training through the
// loop with the plant model, NARX or state-space (feedback_training.h, loop_plant.h).

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dsp/biquad.h"
#include "models/control/feedback_training.h"
#include "models/control/lq_feedforward.h"
#include "models/control/loop_plant.h"
#include "models/control/neural_feedback.h"
#include "models/plant/plant_config.h"

namespace panelbass::models {

/// What the loop output is trained to track.
enum class DesiredResponse {
  linear_model,         ///< y_lin of [7B], the linear model behind the feedforward (fig. 7.10, the thesis's)
  plant_small_signal,   ///< the plant model's own small-signal response to the feedforward output u*
                        ///< (small_signal_response): the loop's error is then the model's distortion alone,
                        ///< not the gain gap between the linear and the plant model
  plant_fundamental,    ///< plant_small_signal plus, on each sine step's steady part, the fundamental (and
                        ///< mean) of the uncorrected loop's departure from it (the plant model driven by u*);
                        ///< the rest of a step weighs 0. The error is then the harmonics alone: neither the
                        ///< linear gap nor the amplitude-dependent gain of the fundamental (which near
                        ///< panel-exciter's resonance varies by 3 dB with the drive) is asked of the loop
};

/// "linear-model", "plant-small-signal" or "plant-fundamental".
const char* desired_response_name(DesiredResponse d);
/// The DesiredResponse named `name`; std::invalid_argument listing the names otherwise.
DesiredResponse desired_response_from_name(const std::string& name);

/// Which of several restarts a design keeps.
enum class RestartChoice {
  validation_jc,  ///< the lowest validation J_c on the plant model (what the training minimises)
  worst_probe,    ///< the largest THD cut at its worst probe on the plant model (model_thd_change_db at the
                  ///< records' sine peak): what the controller is judged by, where J_c may hide one probe's miss
};

/// "validation-jc" or "worst-probe".
const char* restart_choice_name(RestartChoice c);
/// The RestartChoice named `name`; std::invalid_argument listing the names otherwise.
RestartChoice restart_choice_from_name(const std::string& name);

/// The fewest samples a training record (control_record) may have.
inline constexpr Eigen::Index kMinControlSamples = 1000;

/// How the controller is designed.
struct FeedbackDesignOptions {
  FeedbackStructure structure{};     ///< N1's inputs and hidden layers
  Eigen::Index samples = 6000;       ///< samples of each record (estimation, validation)
  double sine_share = 0.75;          ///< share of a record made of stepped sines (the rest: white noise)
  double sine_low_hz = 30.0;         ///< stepped sines: lowest frequency, Hz (log-uniform draw)
  double sine_high_hz = 400.0;       ///< stepped sines: highest frequency, Hz
  double sine_step_seconds = 0.25;   ///< stepped sines: duration of each
  double sine_peak = 0.6;            ///< stepped sines: steady peak of the feedforward output, in (0, 1]; below the
                                     ///< soft limit's knee (0.8), so the controller has headroom to correct
  double program_share = 0.0;        ///< share of the stepped sines played at a program level (the same program
                                     ///< amplitude range at every frequency, as music would), the rest at a drive
                                     ///< level (steady drive peak sine_peak at each step's own frequency, or
                                     ///< program peak sine_peak where the chain's gain is below 1)
  bool level_weighting = false;      ///< weight each part of a record (the noise, every sine step) by the inverse
                                     ///< of its desired output's power, so a small step's relative error counts as
                                     ///< much as a loud one's (otherwise a step at a twelfth of the level counts
                                     ///< 1/144 as much, and the harmonics of small drives are all but invisible)
  bool distortion_weighting = false;  ///< weight each part of a record by the inverse of the power of the
                                      ///< uncorrected loop's error there (the plant model driven by u* against
                                      ///< y_desired; with the plant-small-signal target, the model's distortion),
                                      ///< so that every part's error counts in dB alike: a step with 0.5 %
                                      ///< distortion as much as one with 60 % (needs the plant model)
  DesiredResponse desired = DesiredResponse::linear_model;  ///< what the loop output tracks
  std::uint64_t seed = 1;            ///< records (estimation: seed, validation: seed + 1) and initial weights
  int restarts = 1;                  ///< trainings from different initial weights on the same records
  RestartChoice keep = RestartChoice::validation_jc;  ///< which restart is kept
  std::vector<double> probe_hz;      ///< the probes RestartChoice::worst_probe scores by, Hz; empty: evaluate's
                                     ///< (evaluation_probe_hz)
  int device_playbacks = 1;          ///< tuning on the device: each drive is played this many times and the
                                     ///< outputs averaged (the sensor noise's power falls by that factor)
  FeedbackTrainingOptions training{};  ///< the training itself
};

/// One stepped sine of a control record.
struct SineStep {
  Eigen::Index start = 0, length = 0;  ///< its samples
  double f = 0.0;                      ///< frequency, Hz
  Eigen::Index fade = 0;               ///< samples of fade at each end
};

/// A stretch of a record that is weighed as one.
struct RecordPart {
  Eigen::Index start = 0, length = 0;  ///< its samples
};

/// One training record.
struct ControlRecord {
  Eigen::VectorXd program;    ///< the program input
  Eigen::VectorXd u;          ///< the feedforward output u* (band-pass, then [7B]), raw drive units
  Eigen::VectorXd y_desired;  ///< the desired output (FeedbackDesignOptions::desired), raw units
  Eigen::VectorXd weight;     ///< tracking weight per sample (a weighting, or the plant-fundamental target's
                              ///< steady parts), else empty (all 1)
  Eigen::Index noise_samples = 0;  ///< the noise at the start
  std::vector<SineStep> steps;     ///< the stepped sines after it
};

/// A record of `o.samples`: uniform white noise at the largest safe amplitude (models::max_input's noise
/// case), then stepped sines at log-uniform random frequencies. A drive-level step plays at the amplitude
/// where band-pass + feedforward reach a steady peak of o.sine_peak at its frequency, or at o.sine_peak where
/// the chain's gain is below 1 (the rule `evaluate` sets its probes by); a program-level step
/// (share o.program_share) at a program amplitude drawn uniformly from a quarter to twice the one at which the
/// band's loudest frequency reaches o.sine_peak, capped at the drive level — so that where the feedforward
/// cuts (near the plant's resonance) the steps are as small as a program makes them. Every step fades in and
/// out over two periods (10 ms at least) and is scaled down where the feedforward's slow transients would
/// lift its drive above o.sine_peak. y_desired as o.desired says (the plant-small-signal target needs `plant`,
/// std::invalid_argument without it), plus, given `plant`, the plant model's rest output (its free run at
/// u = 0), so that the loop tracks the change from rest and is not trained to null the model's offset with a
/// DC drive. Deterministic in `seed`.
ControlRecord control_record(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass,
                             const FeedbackDesignOptions& o, std::uint64_t seed, const LoopPlant* plant = nullptr);
/// control_record on a NARX plant model.
ControlRecord control_record(const LqFeedforward& ff, const std::vector<dsp::Biquad>& band_pass,
                             const FeedbackDesignOptions& o, std::uint64_t seed, const NarxModel* plant);

/// Per-sample weights for identifying a plant model on `record`'s drive u and the plant's measured output
/// `y` (same length, rate fs): every step weighs by the inverse power of its harmonics — the 2nd to 5th
/// (those below fs/2) fitted by least squares to what y departs from the linear response y_desired by on the
/// step's steady part, so that sensor noise hardly counts — and the noise part by the inverse power of its departure, scaled to the record's mean and capped at 10⁴
/// (weigh as control_record's parts do); a whole step (fades included) takes its steady part's weight. So a
/// step whose harmonics sit 40 dB under its fundamental counts as much as one with 60 % distortion. Throws
/// std::invalid_argument for a length mismatch or a non-finite y.
Eigen::VectorXd harmonic_weights(const ControlRecord& record, const Eigen::VectorXd& y, double fs);

/// What the design produced.
struct FeedbackDesign {
  NeuralFeedback controller;              ///< the trained controller
  FeedbackTrainingResult training;        ///< its training history
  std::vector<double> restart_jc_val_pct;  ///< every restart's best validation J_c, percent
  std::vector<std::vector<double>> restart_probe_change_db;  ///< with RestartChoice::worst_probe, every restart's
                                                             ///< THD change per probe on the plant model, dB
  int chosen_restart = 0;                 ///< the restart kept
};

/// The options a design ran with, as a controller file's meta and a design's report list them:
/// {"samples","max_iterations","hidden","nu","nv","ny","sine_share","sine_peak","sine_band","program_share","restarts",
///  "keep","probe_hz","level_weighting","distortion_weighting","device_playbacks","rail_penalty","dc_penalty",
///  "desired","seed"}.
nlohmann::json feedback_design_options_json(const FeedbackDesignOptions& o);

/// The device's sensor noise in tuning (design_feedback's `device`) is seeded seed + this (estimation record)
/// and seed + this + 1 (validation), plus kPlaybackSeedStride·i for playback i.
inline constexpr std::uint64_t kDeviceNoiseSeedOffset = 1000;
/// See kDeviceNoiseSeedOffset.
inline constexpr std::uint64_t kPlaybackSeedStride = 1000000;

/// The steady part of a sine step: from two fades in (the resonances' transients settled) to its fade out;
/// a length below 4 when the step is too short to have one.
RecordPart steady_part(const SineStep& step);

/// Designs the controller on `plant` (a NARX or neural state-space model at ff's rate) behind `ff` and
/// `band_pass`: o.restarts trainings from initial weights seeded seed, seed + 1, … on the same records, the best by o.keep kept
/// (ties to the earlier). Given a `device` (a virtual transducer standing in for the real one), the controller
/// is tuned on it: the records' drives are played into it (o.device_playbacks times, averaged) and the
/// tracking error is its measured output's, while the gradients stay the plant model's
/// (FeedbackTrainingOptions::measure_est). On each sine step's steady part the target is the fundamental and
/// mean of the device's own uncorrected output there and the error counts through its harmonic series alone
/// (HarmonicStretch: the device's harmonics, without the sensor noise between them); the noise at the
/// record's start keeps the plant model's target (the broadband J_c); the fades weigh 0. This needs
/// o.desired = plant_fundamental. Given `start`, one training goes on from its structure, weights and knee
/// (on `plant`, in place of start's own plant model) instead of fresh initial weights. Throws
/// std::invalid_argument for a rate mismatch or bad options.
FeedbackDesign design_feedback(const LoopPlant& plant, const LqFeedforward& ff,
                               const std::vector<dsp::Biquad>& band_pass, const FeedbackDesignOptions& o,
                               const PlantConfig* device = nullptr, const NeuralFeedback* start = nullptr);

}  // namespace panelbass::models

// The neural feedback controller's design records: the program through band-pass and LQ feedforward,
// its levels, and its determinism.
#include <gtest/gtest.h>

#include <Eigen/QR>

#include <algorithm>
#include <array>
#include <limits>
#include <numbers>

#include "dsp/butterworth.h"
#include "dsp/excitation.h"
#include "models/control/feedback_design.h"
#include "models/control/model_probes.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "models/narx/narx_model.h"
#include "models/linear/state_space.h"
#include "tests/support/expect_error.h"
#include "tests/support/linear_systems.h"
#include "tests/support/narx_models.h"

namespace panelbass::models {
namespace {

LinearModel resonant_model() {
  LinearModel m;
  Eigen::VectorXcd poles(2);
  poles << std::polar(0.97, 0.3), std::polar(0.97, -0.3);
  m.tf.a = polynomial_from_roots(poles).tail(2);
  m.tf.b = Eigen::Vector2d(0.05, 0.03);
  m.tf.nk = 1;
  m.fs = 3000.0;
  return m;
}

// The band-pass in front of the controllers: 2nd order, 20–1200 Hz at 3000 Hz.
std::vector<dsp::Biquad> audio_band() { return dsp::butterworth_bandpass(2, 20.0, 1200.0, 3000.0); }

TEST(FeedbackDesignTest, ControlRecordIsTheProgramThroughBandPassAndFeedforward) {
  const LqFeedforward ff = design_lq(resonant_model(), {1e-3, 20.0});
  const std::vector<dsp::Biquad> bp = audio_band();
  FeedbackDesignOptions o;
  o.samples = 6000;
  o.sine_share = 0.5;
  o.sine_peak = 0.3;
  const ControlRecord r = control_record(ff, bp, o, 3);
  ASSERT_EQ(r.u.size(), 6000);
  // u and y_desired are [7B] of the band-passed program, recomputed here with plain loops
  dsp::SosFilter filter(bp);
  const Eigen::VectorXd p = filter.process(r.program);
  const StateSpace& s = ff.plant;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(s.order());
  for (Eigen::Index k = 0; k < p.size(); ++k) {
    ASSERT_NEAR(r.u[k], -ff.L.dot(x) + p[k], 1e-10) << k;
    ASSERT_NEAR(r.y_desired[k], s.C.dot(x) + s.D * p[k], 1e-10) << k;
    x = (s.A - s.B * ff.L) * x + s.B * p[k];
  }
  // the noise half stays within the safe range; the sine half's drive, transients included, and its program
  // stay within sine_peak, and the steps are not scaled further down than they need to be (the drive or,
  // where the chain's gain is below 1, the program reaches it)
  EXPECT_LE(r.u.head(3000).cwiseAbs().maxCoeff(), 1.0 + 1e-9);
  EXPECT_LE(r.u.tail(3000).cwiseAbs().maxCoeff(), 0.3 * 1.005);
  EXPECT_LE(r.program.tail(3000).cwiseAbs().maxCoeff(), 0.3 * 1.005);
  EXPECT_GE(std::max(r.u.tail(3000).cwiseAbs().maxCoeff(), r.program.tail(3000).cwiseAbs().maxCoeff()), 0.3 * 0.95);
  // deterministic in the seed, different for another
  EXPECT_EQ(control_record(ff, bp, o, 3).program, r.program);
  EXPECT_NE(control_record(ff, bp, o, 4).program, r.program);
}

// An accelerometer-like model: a resonance near 150 Hz and a double zero near DC, so that cheap-control LQ
// boosts the band's low edge and gets slow poles there, which every stepped sine's fades excite.
LinearModel accelerometer_model() {
  LinearModel m;
  Eigen::VectorXcd poles(2), zeros(2);
  poles << std::polar(0.985, 0.314), std::polar(0.985, -0.314);
  zeros << 0.995, 0.995;
  m.tf.a = polynomial_from_roots(poles).tail(2);
  m.tf.b = 0.05 * polynomial_from_roots(zeros);
  m.tf.nk = 1;
  m.fs = 3000.0;
  return m;
}

TEST(FeedbackDesignTest, SteppedSinesKeepTheirPeakWhenTheFeedforwardRingsBelowTheBand) {
  const LqFeedforward ff = design_lq(accelerometer_model(), {1e-5, 20.0});
  const std::vector<dsp::Biquad> bp = audio_band();
  FeedbackDesignOptions o;
  o.samples = 12000;
  o.sine_share = 1.0;
  o.sine_low_hz = 25.0;
  o.sine_peak = 0.6;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const ControlRecord r = control_record(ff, bp, o, seed);
    EXPECT_LE(r.u.cwiseAbs().maxCoeff(), 0.6 * 1.005) << "seed " << seed;
    EXPECT_GE(r.u.cwiseAbs().maxCoeff(), 0.6 * 0.95) << "seed " << seed;
  }
}

// The peak of each stepped sine of a record made of sines only (steps of o.sine_step_seconds from the start).
std::vector<double> step_peaks(const Eigen::VectorXd& signal, const FeedbackDesignOptions& o) {
  const auto step = static_cast<Eigen::Index>(o.sine_step_seconds * 3000.0);
  std::vector<double> peaks;
  for (Eigen::Index start = 0; start + step <= signal.size(); start += step) {
    peaks.push_back(signal.segment(start, step).cwiseAbs().maxCoeff());
  }
  return peaks;
}

// Drive-level steps reach the drive peak, or the program does where the chain's gain is below 1, so their
// program amplitudes spread as that gain does (the accelerometer-like model's LQ boosts 30 Hz and cuts near
// its 150 Hz resonance); program-level steps play program amplitudes within a factor 8 of each other
// (a quarter to twice one level), so near the resonance their drive stays far below the peak.
TEST(FeedbackDesignTest, ProgramLevelStepsShareOneAmplitudeRangeDriveLevelStepsOneDrivePeak) {
  const LqFeedforward ff = design_lq(accelerometer_model(), {1e-5, 20.0});
  const std::vector<dsp::Biquad> bp = audio_band();
  FeedbackDesignOptions o;
  o.samples = 30000;  // 40 steps
  o.sine_share = 1.0;
  o.sine_peak = 0.6;
  o.program_share = 0.0;
  const ControlRecord drive_level = control_record(ff, bp, o, 5);
  // most steps reach it, or their program does where the chain's gain is below 1 (some are scaled down
  // where the previous step's transient lifts their drive)
  const std::vector<double> drive_peaks = step_peaks(drive_level.u, o);
  const std::vector<double> drive_programs = step_peaks(drive_level.program, o);
  long reaching = 0;
  for (std::size_t i = 0; i < drive_peaks.size(); ++i) reaching += drive_peaks[i] >= 0.6 * 0.9 || drive_programs[i] >= 0.6 * 0.99;
  EXPECT_GE(reaching, 3 * static_cast<long>(drive_peaks.size()) / 4);
  const auto [dmin, dmax] = std::minmax_element(drive_programs.begin(), drive_programs.end());
  EXPECT_GT(*dmax / *dmin, 10.0) << "the feedforward's gain spreads the drive-level steps' program amplitudes";
  // where the chain's gain is below 1 (near the resonance) the program, not the drive, reaches the peak: the
  // rule evaluate's probes follow (program amplitude = peak / max(1, |gain|))
  EXPECT_LE(*dmax, 0.6 * 1.001);
  EXPECT_GE(*dmax, 0.6 * 0.99) << "no step landed where the chain's gain is below 1";

  o.program_share = 1.0;
  const ControlRecord program_level = control_record(ff, bp, o, 5);
  EXPECT_LE(program_level.u.cwiseAbs().maxCoeff(), 0.6 * 1.005);
  const std::vector<double> programs = step_peaks(program_level.program, o);
  const auto [pmin, pmax] = std::minmax_element(programs.begin(), programs.end());
  EXPECT_LE(*pmax / *pmin, 8.0 * 1.01);
  const std::vector<double> peaks = step_peaks(program_level.u, o);
  EXPECT_LT(*std::min_element(peaks.begin(), peaks.end()), 0.6 / 4.0) << "steps near the resonance stay small";
  o.program_share = 1.5;
  EXPECT_THROW(control_record(ff, bp, o, 5), std::invalid_argument);
}

// Level weighting: the noise part and every step get one weight each, the inverse of their desired output's
// mean power relative to the record's, so that every part then weighs in with the record's mean power (checked
// part by part, from the step grid alone); without it the record has no weights.
// The parts of a record at 3000 Hz (start, length): the noise, then one per sine step.
std::vector<std::pair<Eigen::Index, Eigen::Index>> record_parts(const FeedbackDesignOptions& o, Eigen::Index noise) {
  const auto step = static_cast<Eigen::Index>(o.sine_step_seconds * 3000.0);
  std::vector<std::pair<Eigen::Index, Eigen::Index>> parts{{0, noise}};
  for (Eigen::Index start = noise; start < o.samples; start += step) parts.emplace_back(start, std::min(step, o.samples - start));
  return parts;
}

TEST(FeedbackDesignTest, LevelWeightingGivesEveryPartTheRecordsMeanPower) {
  const LqFeedforward ff = design_lq(accelerometer_model(), {1e-5, 20.0});
  const std::vector<dsp::Biquad> bp = audio_band();
  FeedbackDesignOptions o;
  o.samples = 15000;  // 5000 samples of noise, then 13 steps and a short one
  o.sine_share = 2.0 / 3.0;
  o.program_share = 0.5;
  EXPECT_EQ(control_record(ff, bp, o, 2).weight.size(), 0);
  o.level_weighting = true;
  const ControlRecord r = control_record(ff, bp, o, 2);
  ASSERT_EQ(r.weight.size(), o.samples);
  const double mean_power = r.y_desired.squaredNorm() / static_cast<double>(o.samples);
  double smallest = 1e300, largest = 0.0;
  for (const auto& [start, length] : record_parts(o, 5000)) {
    const Eigen::VectorXd w = r.weight.segment(start, length);
    EXPECT_EQ(w.minCoeff(), w.maxCoeff()) << "one weight per part, at " << start;
    const Eigen::VectorXd y = r.y_desired.segment(start, length);
    EXPECT_NEAR(w[0] * y.squaredNorm() / static_cast<double>(length), mean_power, 1e-9 * mean_power) << start;
    smallest = std::min(smallest, w[0]);
    largest = std::max(largest, w[0]);
  }
  EXPECT_GT(largest / smallest, 10.0) << "program-level steps near the resonance are far quieter than the rest";
}

// A small design with restarts: a random 3-node NARX plant behind the resonant model's LQ feedforward, three
// restarts of four iterations each.
struct RestartsCase {
  LqFeedforward ff;
  std::vector<dsp::Biquad> bp;
  NarxModel plant;
  FeedbackDesignOptions options;
};

RestartsCase restarts_case() {
  NarxStructure ps;
  ps.na = 2;
  ps.nb = 1;
  ps.hidden = {3};
  RestartsCase c{design_lq(resonant_model(), {1e-3, 20.0}), audio_band(), NarxModel::with_structure(ps, Scaling{}, 3000.0), {}};
  c.plant.net.initialize(0.5, 7);
  c.options.structure.nu = 1;
  c.options.structure.nv = 1;
  c.options.structure.ny = 1;
  c.options.structure.hidden = {3};
  c.options.samples = 2000;
  c.options.training.max_iterations = 4;
  c.options.restarts = 3;
  return c;
}

// Restarts train from different initial weights on the same records and keep the best validation J_c: the
// kept controller's J_c, recomputed here from its closed loop on the validation record, is the smallest of
// the restarts', and restart 0 is the design without restarts.
TEST(FeedbackDesignTest, RestartsKeepTheLowestValidationJc) {
  auto [ff, bp, plant, o] = restarts_case();
  const FeedbackDesign d = design_feedback(plant, ff, bp, o);
  ASSERT_EQ(d.restart_jc_val_pct.size(), 3u);
  const auto smallest = std::min_element(d.restart_jc_val_pct.begin(), d.restart_jc_val_pct.end());
  EXPECT_EQ(d.chosen_restart, smallest - d.restart_jc_val_pct.begin());
  const ControlRecord val = control_record(ff, bp, o, o.seed + 1, &plant);
  const double kept = jc_percent(simulate_closed_loop(d.controller, val.u).y, val.y_desired, o.training.transient_skip);
  EXPECT_NEAR(kept, *smallest, 1e-9 * *smallest);
  EXPECT_NE(d.restart_jc_val_pct[0], d.restart_jc_val_pct[1]) << "restarts start from different weights";
  o.restarts = 1;
  const FeedbackDesign single = design_feedback(plant, ff, bp, o);
  ASSERT_EQ(single.restart_jc_val_pct.size(), 1u);
  EXPECT_DOUBLE_EQ(single.restart_jc_val_pct[0], d.restart_jc_val_pct[0]);
  o.restarts = 0;
  EXPECT_THROW(design_feedback(plant, ff, bp, o), std::invalid_argument);
}

// Kept by the worst probe, a design keeps the restart whose largest THD change over the probes on its plant
// model is the most negative: every restart's changes are reported, the kept controller's are recomputed here,
// and probes the model cannot analyse are refused before any training.
TEST(FeedbackDesignTest, RestartsCanKeepTheLargestCutAtTheWorstProbe) {
  auto [ff, bp, plant, o] = restarts_case();
  o.keep = RestartChoice::worst_probe;
  o.probe_hz = {60.0, 200.0};
  const FeedbackDesign d = design_feedback(plant, ff, bp, o);
  ASSERT_EQ(d.restart_probe_change_db.size(), 3u);
  std::vector<double> worst;
  for (const std::vector<double>& changes : d.restart_probe_change_db) {
    ASSERT_EQ(changes.size(), 2u);
    worst.push_back(std::max(changes[0], changes[1]));
  }
  EXPECT_EQ(d.chosen_restart, std::min_element(worst.begin(), worst.end()) - worst.begin());
  EXPECT_NE(worst[0], worst[1]) << "restarts start from different weights";
  const std::vector<double> kept = model_thd_change_db(d.controller, ff, bp, o.probe_hz, o.sine_peak);
  EXPECT_EQ(kept, d.restart_probe_change_db[static_cast<std::size_t>(d.chosen_restart)]);
  // the validation J_c of every restart is still reported, and keeping by it needs no probe
  EXPECT_EQ(d.restart_jc_val_pct.size(), 3u);
  o.keep = RestartChoice::validation_jc;
  EXPECT_TRUE(design_feedback(plant, ff, bp, o).restart_probe_change_db.empty());
  o.keep = RestartChoice::worst_probe;
  o.probe_hz = {60.0, 900.0};
  o.training.max_iterations = 100000;  // refused before the first iteration, or this would take hours
  EXPECT_THROW(design_feedback(plant, ff, bp, o), std::invalid_argument);
}

// Trained on from a controller, a design starts where it is: with no iteration the weights are its own, with
// some the validation J_c starts at its figure and does not rise; several restarts from one start are refused.
TEST(FeedbackDesignTest, TrainingOnFromAControllerStartsWhereItIs) {
  auto [ff, bp, plant, o] = restarts_case();
  o.restarts = 1;
  const FeedbackDesign first = design_feedback(plant, ff, bp, o);
  FeedbackDesignOptions on = o;
  on.structure.hidden = {7};  // the start's structure wins
  on.training.max_iterations = 0;
  const FeedbackDesign kept = design_feedback(plant, ff, bp, on, nullptr, &first.controller);
  EXPECT_EQ(kept.controller.net.parameters(), first.controller.net.parameters());
  EXPECT_EQ(kept.controller.structure.hidden, first.controller.structure.hidden);
  on.training.max_iterations = 3;
  const FeedbackDesign further = design_feedback(plant, ff, bp, on, nullptr, &first.controller);
  EXPECT_NEAR(further.training.history.front().jc_val_pct, best_validation_jc_pct(first.training),
              1e-9 * best_validation_jc_pct(first.training));
  EXPECT_LE(best_validation_jc_pct(further.training), best_validation_jc_pct(first.training));
  on.restarts = 2;
  EXPECT_THROW(design_feedback(plant, ff, bp, on, nullptr, &first.controller), std::invalid_argument);
}

// y(k) = tanh(0.5·y(k−1) + 1.5·u(k)) + offset.
NarxModel tanh_narx_plant(double offset) {
  return testing_support::one_node_narx(0.5, 1.5, 0.0, 1.0, offset, Scaling{}, 3000.0);
}

// Its rest trajectory r(k) = tanh(0.5·r(k−1)) + offset from r(−1) = 0, and the slope along it,
// s(k) = 1 − tanh²(0.5·r(k−1)).
std::pair<Eigen::VectorXd, Eigen::VectorXd> tanh_plant_rest_and_slope(double offset, Eigen::Index n) {
  Eigen::VectorXd rest(n), slope(n);
  double r = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    const double t = std::tanh(0.5 * r);
    slope[k] = 1.0 - t * t;
    rest[k] = r = t + offset;
  }
  return {rest, slope};
}

TEST(FeedbackDesignTest, PlantSmallSignalTargetIsThePlantModelsLinearisationOfTheDriveFromItsRest) {
  const LqFeedforward ff = design_lq(resonant_model(), {1e-3, 20.0});
  const double offset = 0.3;
  const NarxModel plant = tanh_narx_plant(offset);
  FeedbackDesignOptions o;
  o.samples = 6000;
  o.sine_share = 1.0;  // stepped sines only: the noise part plays at full scale, far into the tanh
  o.sine_peak = 0.1;
  o.desired = DesiredResponse::plant_small_signal;
  const ControlRecord r = control_record(ff, audio_band(), o, 4, &plant);
  // closed form: the rest trajectory plus the linearisation along it, δy(k) = s(k)·(0.5·δy(k−1) + 1.5·u(k))
  const auto [rest, slope] = tanh_plant_rest_and_slope(offset, r.u.size());
  Eigen::VectorXd expected(r.u.size());
  double dy = 0.0;
  for (Eigen::Index k = 0; k < r.u.size(); ++k) {
    dy = slope[k] * (0.5 * dy + 1.5 * r.u[k]);
    expected[k] = rest[k] + dy;
  }
  const double scale = expected.cwiseAbs().maxCoeff();
  for (Eigen::Index k = 0; k < r.u.size(); ++k) ASSERT_NEAR(r.y_desired[k], expected[k], 1e-8 * scale) << k;
  // the drive is the thesis's, whatever the target
  FeedbackDesignOptions thesis = o;
  thesis.desired = DesiredResponse::linear_model;
  const ControlRecord t = control_record(ff, audio_band(), thesis, 4, &plant);
  EXPECT_EQ(t.u, r.u);
  // the uncorrected loop's error is then the plant model's distortion alone, far below the gap the thesis's
  // target (the resonant linear model, another system) leaves
  const Eigen::VectorXd loop = plant.simulate(r.u);
  EXPECT_LT((loop - r.y_desired).norm(), 0.1 * (loop - t.y_desired).norm());
  EXPECT_GT((loop - r.y_desired).norm(), 0.0);
  // without the plant model there is no small-signal target
  EXPECT_THROW(control_record(ff, audio_band(), o, 4), std::invalid_argument);
}

TEST(FeedbackDesignTest, GivenThePlantModelTheThesissTargetIsMeasuredFromItsRest) {
  const LqFeedforward ff = design_lq(resonant_model(), {1e-3, 20.0});
  const double offset = -0.2;
  const NarxModel plant = tanh_narx_plant(offset);
  FeedbackDesignOptions o;
  o.samples = 3000;
  const ControlRecord with = control_record(ff, audio_band(), o, 6, &plant);
  const ControlRecord without = control_record(ff, audio_band(), o, 6);
  const Eigen::VectorXd rest = tanh_plant_rest_and_slope(offset, with.u.size()).first;
  EXPECT_LT((with.y_desired - without.y_desired - rest).cwiseAbs().maxCoeff(), 1e-12);
}

// Distortion weighting: every part's uncorrected error (the plant model driven by u*, against the
// plant-small-signal target: its distortion alone), times the part's weight, has the record's mean power
// (unless the weight reaches its cap of 1e4).
TEST(FeedbackDesignTest, DistortionWeightingGivesEveryPartsErrorTheRecordsMeanPower) {
  const LqFeedforward ff = design_lq(resonant_model(), {1e-3, 20.0});
  const NarxModel plant = tanh_narx_plant(0.0);
  FeedbackDesignOptions o;
  o.samples = 6000;  // 1500 samples of noise, then 6 steps and a short one
  o.sine_share = 0.75;
  o.sine_peak = 0.3;
  o.desired = DesiredResponse::plant_small_signal;
  o.distortion_weighting = true;
  const ControlRecord r = control_record(ff, audio_band(), o, 3, &plant);
  ASSERT_EQ(r.weight.size(), o.samples);
  const Eigen::VectorXd error = plant.simulate(r.u) - r.y_desired;
  const double mean_power = error.squaredNorm() / static_cast<double>(o.samples);
  double smallest = 1e300, largest = 0.0;
  for (const auto& [start, length] : record_parts(o, 1500)) {
    const Eigen::VectorXd w = r.weight.segment(start, length);
    EXPECT_EQ(w.minCoeff(), w.maxCoeff()) << "one weight per part, at " << start;
    const double power = error.segment(start, length).squaredNorm() / static_cast<double>(length);
    EXPECT_NEAR(w[0], std::min(1e4, mean_power / power), 1e-9 * w[0]) << start << " (weights are capped at 1e4)";
    smallest = std::min(smallest, w[0]);
    largest = std::max(largest, w[0]);
  }
  EXPECT_GT(largest / smallest, 10.0) << "the loud noise distorts far more than the sines";
  // it needs the plant model, and it is not level weighting too
  EXPECT_THROW(control_record(ff, audio_band(), o, 3), std::invalid_argument);
  o.level_weighting = true;
  EXPECT_THROW(control_record(ff, audio_band(), o, 3, &plant), std::invalid_argument);
}

// The contiguous runs of weight 1 after the first `from` samples: (start, length).
std::vector<std::pair<Eigen::Index, Eigen::Index>> weighed_runs(const Eigen::VectorXd& weight, Eigen::Index from) {
  std::vector<std::pair<Eigen::Index, Eigen::Index>> runs;
  for (Eigen::Index k = from; k < weight.size();) {
    if (weight[k] == 0.0) {
      ++k;
      continue;
    }
    Eigen::Index end = k;
    while (end < weight.size() && weight[end] == 1.0) ++end;
    runs.emplace_back(k, end - k);
    k = end;
  }
  return runs;
}

// The least-squares fit of x by c + Σ a_h·sin(hωk) + b_h·cos(hωk) over the harmonics h = 1..`harmonics` of
// f Hz below fs/2 (3000 Hz sampling): its residual.
Eigen::VectorXd residual_of_sine_fit(const Eigen::VectorXd& x, double f, int harmonics = 1) {
  while (harmonics * f >= 1500.0) --harmonics;
  Eigen::MatrixXd basis(x.size(), 2 * harmonics + 1);
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    basis(k, 0) = 1.0;
    for (int h = 1; h <= harmonics; ++h) {
      basis(k, 2 * h - 1) = std::sin(2.0 * std::numbers::pi * h * f * k / 3000.0);
      basis(k, 2 * h) = std::cos(2.0 * std::numbers::pi * h * f * k / 3000.0);
    }
  }
  return x - basis * basis.colPivHouseholderQr().solve(x);
}

// The frequency of a pure sine, by the least-squares fit with the smallest residual (0.5 Hz grid, then 1 mHz).
double sine_frequency(const Eigen::VectorXd& x) {
  double best = 30.0, smallest = 1e300;
  const auto search = [&](double lo, double hi, double step) {
    for (double f = lo; f <= hi; f += step) {
      const double r = residual_of_sine_fit(x, f).squaredNorm();
      if (r < smallest) {
        smallest = r;
        best = f;
      }
    }
  };
  search(29.0, 401.0, 0.5);
  search(best - 0.5, best + 0.5, 0.001);
  return best;
}

TEST(FeedbackDesignTest, PlantFundamentalTargetLeavesOnlyTheHarmonicsOfEachSteadyStep) {
  const LqFeedforward ff = design_lq(resonant_model(), {1e-3, 20.0});
  FeedbackDesignOptions o;
  o.samples = 4500;  // 1500 samples of noise, then 4 steps
  o.sine_share = 2.0 / 3.0;
  o.sine_peak = 0.6;
  o.desired = DesiredResponse::plant_fundamental;
  // y = 1000·tanh(0.0005·y(k−1) + 0.0015·u(k)): linear to 1e-6, so nothing is left to correct
  NarxModel linear = tanh_narx_plant(0.0);
  linear.net.parameters() << 0.0005, 0.0015, 0.0, 1000.0, 0.0;
  const ControlRecord quiet = control_record(ff, audio_band(), o, 8, &linear);
  const Eigen::VectorXd quiet_error = (linear.simulate(quiet.u) - quiet.y_desired).cwiseProduct(quiet.weight);
  EXPECT_LT(quiet_error.norm(), 1e-5 * quiet.y_desired.norm());

  const NarxModel plant = tanh_narx_plant(0.0);
  const ControlRecord r = control_record(ff, audio_band(), o, 8, &plant);
  FeedbackDesignOptions small_signal = o;
  small_signal.desired = DesiredResponse::plant_small_signal;
  const ControlRecord s = control_record(ff, audio_band(), small_signal, 8, &plant);
  EXPECT_EQ(r.u, s.u);
  const Eigen::VectorXd loop = plant.simulate(r.u);
  // the noise: weighed, and tracked as with the small-signal target
  EXPECT_EQ(r.weight.head(1500), Eigen::VectorXd::Ones(1500));
  EXPECT_EQ(r.y_desired.head(1500), s.y_desired.head(1500));
  // the steps: weight 0 or 1, 0 at each step's ends, and one steady run per step
  EXPECT_TRUE(((r.weight.array() == 0.0) || (r.weight.array() == 1.0)).all());
  for (Eigen::Index start = 1500; start < o.samples; start += 750) {
    EXPECT_EQ(r.weight[start], 0.0) << start;
    EXPECT_EQ(r.weight[start + 749], 0.0) << start;
  }
  const auto runs = weighed_runs(r.weight, 1500);
  ASSERT_EQ(runs.size(), 4u);
  for (const auto& [start, length] : runs) {
    ASSERT_GT(length, 300) << start;
    // on it, the error has nothing at the step's frequency (found from the program) and less than the
    // small-signal target leaves (the level's change of the fundamental is gone), but it is not zero
    const double f = sine_frequency(r.program.segment(start, length));
    const Eigen::VectorXd error = loop.segment(start, length) - r.y_desired.segment(start, length);
    const Eigen::VectorXd departure = loop.segment(start, length) - s.y_desired.segment(start, length);
    const double fundamental_before = (departure - residual_of_sine_fit(departure, f)).norm();
    EXPECT_LT((error - residual_of_sine_fit(error, f)).norm(), 1e-4 * fundamental_before) << f << " Hz";
    EXPECT_LT(error.norm(), 0.5 * departure.norm()) << f << " Hz";
    EXPECT_GT(error.norm(), 1e-4 * loop.segment(start, length).norm()) << f << " Hz: the harmonics";
  }
}

// Tuned on a device, the loop is asked the device's harmonics on the steps and its departure from the plant
// model's target on the noise: the first J_c of the training, worked out here from the device's own outputs
// (two playbacks averaged; on each steady step the fundamental and mean fitted to its uncorrected output are
// the target and the output counts through its fit by the five harmonics; the fades weigh nothing), is the
// design's; and what the device tuning cannot take is refused, named.
TEST(FeedbackDesignTest, TunedOnADeviceTheLoopIsAskedTheDevicesHarmonicsAndTheNoisesTarget) {
  const LqFeedforward ff = design_lq(resonant_model(), {1e-3, 20.0});
  FeedbackDesignOptions o;
  o.samples = 4500;  // 1500 samples of noise, then 4 steps
  o.sine_share = 2.0 / 3.0;
  o.desired = DesiredResponse::plant_fundamental;
  o.structure.hidden = {3};
  o.training.max_iterations = 0;
  o.device_playbacks = 2;
  const NarxModel plant = tanh_narx_plant(0.0);
  const PlantConfig device = plant_preset("panel-exciter");
  const FeedbackDesign d = design_feedback(plant, ff, audio_band(), o, &device);
  const ControlRecord val = control_record(ff, audio_band(), o, o.seed + 1, &plant);
  const auto device_output = [&](const Eigen::VectorXd& v) {
    const std::uint64_t seed = o.seed + kDeviceNoiseSeedOffset + 1;
    return Eigen::VectorXd(0.5 * (simulate(device, v, seed).y + simulate(device, v, seed + kPlaybackSeedStride).y));
  };
  const Eigen::VectorXd uncorrected = device_output(val.u);
  const Eigen::VectorXd y = device_output(simulate_closed_loop(d.controller, val.u).v);
  const Eigen::Index skip = o.training.transient_skip;
  double error = (y - val.y_desired).segment(skip, 1500 - skip).squaredNorm();
  double energy = val.y_desired.segment(skip, 1500 - skip).squaredNorm();
  for (const SineStep& step : val.steps) {
    const Eigen::Index start = step.start + 2 * step.fade, length = step.length - 3 * step.fade;
    const Eigen::VectorXd part = uncorrected.segment(start, length);
    const Eigen::VectorXd target = part - residual_of_sine_fit(part, step.f);
    const Eigen::VectorXd departure = y.segment(start, length) - target;
    error += (departure - residual_of_sine_fit(departure, step.f, 5)).squaredNorm();
    energy += target.squaredNorm();
  }
  ASSERT_EQ(val.noise_samples, 1500);
  ASSERT_EQ(val.steps.size(), 4u);
  ASSERT_EQ(d.training.history.size(), 1u);
  EXPECT_NEAR(d.training.history[0].jc_val_pct, 100.0 * error / energy, 1e-6 * d.training.history[0].jc_val_pct);
  FeedbackDesignOptions no_playback = o;
  no_playback.device_playbacks = 0;
  testing_support::expect_invalid([&] { design_feedback(plant, ff, audio_band(), no_playback, &device); }, "playbacks");
  // the device at another rate, another target, or level weighting: refused
  PlantConfig fast = device;
  fast.fs = 6000.0;
  EXPECT_THROW(design_feedback(plant, ff, audio_band(), o, &fast), std::invalid_argument);
  FeedbackDesignOptions linear_target = o;
  linear_target.desired = DesiredResponse::linear_model;
  EXPECT_THROW(design_feedback(plant, ff, audio_band(), linear_target, &device), std::invalid_argument);
  FeedbackDesignOptions level = o;
  level.level_weighting = true;
  EXPECT_THROW(design_feedback(plant, ff, audio_band(), level, &device), std::invalid_argument);
}

TEST(FeedbackDesignTest, HarmonicWeightsGiveEveryStepsHarmonicsTheRecordsMeanPower) {
  const LqFeedforward ff = design_lq(resonant_model(), {1e-3, 20.0});
  FeedbackDesignOptions o;
  o.samples = 4500;  // 1500 samples of noise, then 4 steps
  o.sine_share = 2.0 / 3.0;
  o.sine_peak = 0.6;
  o.sine_high_hz = 400.0;  // third harmonics below fs/2
  const ControlRecord r = control_record(ff, audio_band(), o, 8);
  ASSERT_EQ(r.noise_samples, 1500);
  ASSERT_EQ(r.steps.size(), 4u);
  // A measured output: the linear response plus, on step i, a third harmonic of amplitude a_i, and on the
  // noise a white departure of power b²/3; sensor noise on the steps as strong as the weakest harmonic
  const double fs = ff.fs, b = 0.02;
  const std::array<double, 4> a{0.1, 0.01, 0.03, 0.003};
  Eigen::VectorXd y = r.y_desired;
  y.head(1500) += dsp::uniform_noise(1500, b, 9);
  y.tail(3000) += dsp::uniform_noise(3000, 0.003 * std::sqrt(1.5), 10);
  for (std::size_t i = 0; i < 4; ++i) {
    const SineStep& st = r.steps[i];
    for (Eigen::Index k = 0; k < st.length; ++k) {
      y[st.start + k] += a[i] * std::sin(3.0 * 2.0 * std::numbers::pi * st.f * static_cast<double>(k) / fs + 0.4);
    }
  }
  const Eigen::VectorXd w = harmonic_weights(r, y, fs);
  ASSERT_EQ(w.size(), y.size());
  // one weight per part, inversely proportional to its harmonics' power (a_i²/2) or the noise's (b²/3)
  EXPECT_EQ(w.head(1500), Eigen::VectorXd::Constant(1500, w[0]));
  for (std::size_t i = 0; i < 4; ++i) {
    const SineStep& st = r.steps[i];
    EXPECT_EQ(w.segment(st.start, st.length), Eigen::VectorXd::Constant(st.length, w[st.start])) << i;
    const double expected = (a[0] * a[0]) / (a[i] * a[i]);
    EXPECT_NEAR(w[st.start] / w[r.steps[0].start], expected, 0.15 * expected) << i;
  }
  const double noise_expected = (a[0] * a[0] / 2.0) / (b * b / 3.0);
  EXPECT_NEAR(w[0] / w[r.steps[0].start], noise_expected, 0.1 * noise_expected);
  // a change of each step's fundamental and mean (a level-dependent gain, an offset) weighs nothing
  Eigen::VectorXd shifted = y;
  for (const SineStep& st : r.steps) {
    for (Eigen::Index k = 0; k < st.length; ++k) {
      shifted[st.start + k] += 0.3 * std::sin(2.0 * std::numbers::pi * st.f * static_cast<double>(k) / fs + 1.0) + 0.05;
    }
  }
  EXPECT_LT((harmonic_weights(r, shifted, fs) - w).cwiseAbs().maxCoeff(), 1e-6 * w.maxCoeff());
  // bad output
  EXPECT_THROW(harmonic_weights(r, y.head(100), fs), std::invalid_argument);
  Eigen::VectorXd broken = y;
  broken[2000] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(harmonic_weights(r, broken, fs), std::invalid_argument);
}

TEST(FeedbackDesignTest, DesiredResponseNamesRoundTrip) {
  for (DesiredResponse d :
       {DesiredResponse::linear_model, DesiredResponse::plant_small_signal, DesiredResponse::plant_fundamental}) {
    EXPECT_EQ(desired_response_from_name(desired_response_name(d)), d);
  }
  EXPECT_THROW(desired_response_from_name("flat"), std::invalid_argument);
  for (RestartChoice c : {RestartChoice::validation_jc, RestartChoice::worst_probe}) {
    EXPECT_EQ(restart_choice_from_name(restart_choice_name(c)), c);
  }
  EXPECT_THROW(restart_choice_from_name("best"), std::invalid_argument);
}

TEST(FeedbackDesignTest, RefusesBadOptions) {
  const LqFeedforward ff = design_lq(resonant_model(), {1e-3, 20.0});
  FeedbackDesignOptions peak;
  peak.sine_peak = 1.5;
  EXPECT_THROW(control_record(ff, {}, peak, 1), std::invalid_argument);
  FeedbackDesignOptions band;
  band.sine_high_hz = 2000.0;
  EXPECT_THROW(control_record(ff, {}, band, 1), std::invalid_argument);
  FeedbackDesignOptions samples;
  samples.samples = 10;
  EXPECT_THROW(control_record(ff, {}, samples, 1), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

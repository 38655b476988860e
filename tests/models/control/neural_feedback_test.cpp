// The neural feedback controller (fig. 7.10, Appendix 3): the closed loop, the per-sample runner, the
// exact closed-loop gradient against finite differences, training against a plant whose exact inverse is
// known, and the model file.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <numbers>
#include <vector>

#include "dsp/random.h"
#include "dsp/soft_limit.h"
#include "models/io/config_error.h"
#include "models/control/feedback_training.h"
#include "models/control/neural_feedback.h"
#include "tests/support/expect_error.h"

namespace panelbass::models {
namespace {

constexpr double kEpsilon = 0.01;  // the "linear" node's input gain
constexpr double kGain = 1.5;      // the saturating node's input gain

// y(k) = (0.5/ε)·tanh(ε·y(k−1)) + tanh(1.5·v(k−1))/1.5 ≈ 0.5·y(k−1) + tanh(1.5·v(k−1))/1.5:
// a first-order lag behind a saturation whose exact inverse is v = atanh(1.5·u)/1.5.
NarxModel saturating_plant() {
  NarxStructure s;
  s.na = 1;
  s.nb = 0;
  s.nk = 1;
  s.hidden = {2};
  NarxModel m = NarxModel::with_structure(s, Scaling{}, 3000.0);
  // layer 1: rows [ε, 0] and [0, 1.5], biases 0; output: [0.5/ε, 1/1.5], bias 0
  Eigen::VectorXd theta(9);
  theta << kEpsilon, 0.0, 0.0, kGain, 0.0, 0.0, 0.5 / kEpsilon, 1.0 / kGain, 0.0;
  m.net.parameters() = theta;
  return m;
}

// The desired response: the plant without its saturation, y(k) = 0.5·y(k−1) + u(k−1), as plain loops.
Eigen::VectorXd desired_response(const Eigen::VectorXd& u) {
  Eigen::VectorXd y = Eigen::VectorXd::Zero(u.size());
  for (Eigen::Index k = 1; k < u.size(); ++k) y[k] = 0.5 * y[k - 1] + u[k - 1];
  return y;
}

Eigen::VectorXd uniform(Eigen::Index n, double amplitude, std::uint64_t seed) {
  dsp::Rng rng(seed);
  Eigen::VectorXd u(n);
  for (Eigen::Index k = 0; k < n; ++k) u[k] = rng.uniform(-amplitude, amplitude);
  return u;
}

FeedbackStructure small_structure() {
  FeedbackStructure s;
  s.nu = 2;
  s.nv = 2;
  s.ny = 2;
  s.hidden = {6};
  return s;
}

TEST(NeuralFeedbackTest, ZeroWeightsPassTheProgramThroughTheSoftLimit) {
  const NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), saturating_plant());
  const Eigen::VectorXd u = uniform(400, 1.2, 3);
  const ClosedLoopRun run = simulate_closed_loop(c, u);
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    ASSERT_DOUBLE_EQ(run.v[k], dsp::soft_limit(u[k], c.knee)) << k;
    ASSERT_LE(std::abs(run.v[k]), 1.0);
  }
  const Eigen::VectorXd y_open = c.plant.simulate(run.v);
  EXPECT_LT((run.y - y_open).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(NeuralFeedbackTest, RunnerMatchesTheClosedLoopSimulation) {
  NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), saturating_plant());
  initialize_feedback(c, 7, 1.0);
  const Eigen::VectorXd u = uniform(500, 0.6, 4);
  const ClosedLoopRun run = simulate_closed_loop(c, u);
  FeedbackRunner runner(c);
  for (int pass = 0; pass < 2; ++pass) {  // the second pass checks reset()
    for (Eigen::Index k = 0; k < u.size(); ++k) {
      const double v = runner.control(u[k]);
      const double y = runner.plant_model_output();
      runner.push_output(y);
      ASSERT_NEAR(v, run.v[k], 1e-12) << k;
      ASSERT_NEAR(y, run.y[k], 1e-12) << k;
    }
    runner.reset();
  }
}

TEST(NeuralFeedbackTest, RunnerRefusesAPlantModelWhoseNetworkDisagreesWithItsStructure) {
  NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), saturating_plant());
  EXPECT_NO_THROW(FeedbackRunner{c});
  NarxModel& narx = std::get<NarxModel>(c.plant.model);
  narx.net = Mlp(narx.structure.inputs() + 1, {3});
  EXPECT_THROW(FeedbackRunner{c}, std::invalid_argument);
  c = NeuralFeedback::with_structure(small_structure(), saturating_plant());
  c.net = Mlp(c.structure.inputs() + 2, {3});
  EXPECT_THROW(FeedbackRunner{c}, std::invalid_argument);
}

// The central finite difference (step 1e-6) of `loss` in each of c's parameters.
Eigen::VectorXd finite_difference(const NeuralFeedback& c, const std::function<double(const NeuralFeedback&)>& loss) {
  constexpr double h = 1e-6;
  Eigen::VectorXd fd(c.net.parameter_count());
  for (Eigen::Index i = 0; i < fd.size(); ++i) {
    NeuralFeedback plus = c, minus = c;
    plus.net.parameters()[i] += h;
    minus.net.parameters()[i] -= h;
    fd[i] = (loss(plus) - loss(minus)) / (2 * h);
  }
  return fd;
}

TEST(NeuralFeedbackTest, ClosedLoopGradientMatchesFiniteDifferences) {
  NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), saturating_plant());
  initialize_feedback(c, 11, 1.0);
  const Eigen::VectorXd u = uniform(600, 0.9, 5);  // loud enough that the rail penalty is active
  const Eigen::VectorXd y_des = desired_response(u);
  constexpr double kLambda = 10.0;
  constexpr Eigen::Index kSkip = 20;
  const ClosedLoopRun run = simulate_closed_loop(c, u);
  ASSERT_GT((run.s.array().abs() > c.knee).count(), 10) << "the penalty must be exercised";
  const Eigen::VectorXd g = feedback_gradient(c, u, y_des, kLambda, kSkip);
  Eigen::VectorXd fd = finite_difference(c, [&](const NeuralFeedback& x) { return feedback_loss(x, u, y_des, kLambda, kSkip); });
  EXPECT_LT((g - fd).norm(), 1e-5 * fd.norm()) << "exact " << g.head(5).transpose() << "\nfd    " << fd.head(5).transpose();

  // Per-sample tracking weights (level weighting): the exact gradient of the weighted loss, checked alike.
  const Eigen::VectorXd w = uniform(600, 1.0, 9).array().abs() * 3.0;
  const Eigen::VectorXd gw = feedback_gradient(c, u, y_des, kLambda, kSkip, w);
  fd = finite_difference(c, [&](const NeuralFeedback& x) { return feedback_loss(x, u, y_des, kLambda, kSkip, w); });
  EXPECT_LT((gw - fd).norm(), 1e-5 * fd.norm()) << "exact " << gw.head(5).transpose() << "\nfd    " << fd.head(5).transpose();
  EXPECT_GT((gw - g).norm(), 1e-3 * g.norm()) << "the weights change the gradient";
  // Weights of 1 are no weights.
  EXPECT_LT((feedback_gradient(c, u, y_des, kLambda, kSkip, Eigen::VectorXd::Ones(600)) - g).norm(), 1e-12 * g.norm());
  testing_support::expect_invalid([&] { feedback_loss(c, u, y_des, kLambda, kSkip, Eigen::VectorXd::Ones(599)); }, "599");
  Eigen::VectorXd negative = Eigen::VectorXd::Ones(600);
  negative[123] = -1.0;
  testing_support::expect_invalid([&] { feedback_loss(c, u, y_des, kLambda, kSkip, negative); }, "sample 123");

  // The drive-offset penalty: its exact gradient, checked alike (with the weights, so all terms are on).
  constexpr double kMu = 3.0;
  const Eigen::VectorXd gd = feedback_gradient(c, u, y_des, kLambda, kSkip, w, kMu);
  fd = finite_difference(c, [&](const NeuralFeedback& x) { return feedback_loss(x, u, y_des, kLambda, kSkip, w, kMu); });
  EXPECT_LT((gd - fd).norm(), 1e-5 * fd.norm()) << "exact " << gd.head(5).transpose() << "\nfd    " << fd.head(5).transpose();
  EXPECT_GT((gd - gw).norm(), 1e-3 * gw.norm()) << "the penalty changes the gradient";
}

// N1 = b (only its output bias set): the drive carries the offset b, and the penalty adds
// μ/(2(N − skip))·Σ_{k≥skip} low(k)² with low(k) = b·(1 − a^{k+1}), a = e^{−2π·5/fs}, to the loss.
TEST(NeuralFeedbackTest, DriveOffsetPenaltyIsTheLowPassedOffsetSquared) {
  NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), saturating_plant());
  constexpr double b = 0.03, kMu = 2.0;
  constexpr Eigen::Index kSkip = 40, n = 3000;
  c.net.parameters()[c.net.parameter_count() - 1] = b;
  const Eigen::VectorXd u = uniform(n, 0.3, 8);
  const Eigen::VectorXd y_des = desired_response(u);
  const double a = std::exp(-2.0 * std::numbers::pi * 5.0 / c.fs);
  double expected = 0.0;
  for (Eigen::Index k = kSkip; k < n; ++k) expected += std::pow(b * (1.0 - std::pow(a, k + 1)), 2);
  expected *= kMu / (2.0 * static_cast<double>(n - kSkip));
  const double added = feedback_loss(c, u, y_des, 10.0, kSkip, {}, kMu) - feedback_loss(c, u, y_des, 10.0, kSkip);
  EXPECT_NEAR(added, expected, 1e-10 * expected);
  // without the bias N1 is zero everywhere, and so is the penalty
  c.net.parameters()[c.net.parameter_count() - 1] = 0.0;
  EXPECT_EQ(feedback_loss(c, u, y_des, 10.0, kSkip, {}, kMu), feedback_loss(c, u, y_des, 10.0, kSkip));
}

// A controller of small_structure() on `plant` with the initial weights of seed 1.
NeuralFeedback initialized_controller(const NarxModel& plant) {
  NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), plant);
  initialize_feedback(c, 1);
  return c;
}

// The validation record of the trainings below (uniform noise of peak 0.4), and the training on it and its
// estimation record.
Eigen::VectorXd validation_noise() { return uniform(2000, 0.4, 22); }

FeedbackTrainingResult train_on_noise(const NeuralFeedback& c, const FeedbackTrainingOptions& o) {
  const Eigen::VectorXd u_est = uniform(3000, 0.4, 21), u_val = validation_noise();
  return train_feedback(c, u_est, desired_response(u_est), u_val, desired_response(u_val), o);
}

// The largest departure of a run's drive from the saturation's exact inverse atanh(1.5·u)/1.5, after 50 samples.
double departure_from_inverse(const ClosedLoopRun& run, const Eigen::VectorXd& u) {
  double worst = 0.0;
  for (Eigen::Index k = 50; k < u.size(); ++k) worst = std::max(worst, std::abs(run.v[k] - std::atanh(kGain * u[k]) / kGain));
  return worst;
}

TEST(NeuralFeedbackTest, TrainingLearnsTheInverseOfTheSaturation) {
  const NeuralFeedback c = initialized_controller(saturating_plant());
  FeedbackTrainingOptions o;
  o.max_iterations = 30;
  const FeedbackTrainingResult r = train_on_noise(c, o);
  const Eigen::VectorXd u_val = validation_noise();
  const double before = r.history.front().jc_val_pct;
  const double after = jc_percent(simulate_closed_loop(r.controller, u_val).y, desired_response(u_val), o.transient_skip);
  EXPECT_GT(before, 0.5) << "the saturation must matter at this level";
  EXPECT_LT(after, before / 20.0) << "before " << before << " %, after " << after << " %";
  // the learnt map is the plant's inverse: v ≈ atanh(1.5·u)/1.5 on the validation record
  EXPECT_LT(departure_from_inverse(simulate_closed_loop(r.controller, u_val), u_val), 0.02);
}

// The saturating plant without its saturation: y(k) = 0.5·y(k−1) + v(k−1) through nodes of input gain ε, a
// plant model that knows the dynamics and nothing of the distortion.
NarxModel linear_plant_model() {
  NarxModel m = saturating_plant();
  m.net.parameters() << kEpsilon, 0.0, 0.0, kEpsilon, 0.0, 0.0, 0.5 / kEpsilon, 1.0 / kEpsilon, 0.0;
  return m;
}

// A device whose output is the plant model's own: tuning on it is training on the model, step for step.
TEST(NeuralFeedbackTest, TuningOnADeviceThatIsThePlantModelIsTrainingOnTheModel) {
  const NeuralFeedback c = initialized_controller(saturating_plant());
  FeedbackTrainingOptions o;
  o.max_iterations = 5;
  const FeedbackTrainingResult on_model = train_on_noise(c, o);
  const NarxModel device = saturating_plant();
  o.measure_est = o.measure_val = [&device](const Eigen::VectorXd& v) { return device.simulate(v); };
  const FeedbackTrainingResult on_device = train_on_noise(c, o);
  ASSERT_EQ(on_device.history.size(), on_model.history.size());
  for (std::size_t i = 0; i < on_model.history.size(); ++i) {
    EXPECT_NEAR(on_device.history[i].jc_est_pct, on_model.history[i].jc_est_pct, 1e-9 * on_model.history[i].jc_est_pct) << i;
    EXPECT_NEAR(on_device.history[i].jc_val_pct, on_model.history[i].jc_val_pct, 1e-9 * on_model.history[i].jc_val_pct) << i;
  }
  EXPECT_TRUE(on_device.controller.net.parameters().isApprox(on_model.controller.net.parameters(), 1e-9));
  // a device that answers with the wrong length is named
  o.measure_est = [](const Eigen::VectorXd& v) { return Eigen::VectorXd(v.head(10)); };
  EXPECT_THROW(train_on_noise(c, o), std::invalid_argument);
}

// Tuned on the saturating device with the gradients of a plant model that has no saturation at all, the
// controller still learns the device's inverse: the model only has to know how a change of drive moves the
// output, the error is measured.
TEST(NeuralFeedbackTest, TuningOnTheDeviceLearnsADistortionThePlantModelLacks) {
  const NeuralFeedback c = initialized_controller(linear_plant_model());
  const Eigen::VectorXd u_val = validation_noise();
  const NarxModel device = saturating_plant();
  FeedbackTrainingOptions o;
  o.max_iterations = 30;
  // on the model alone there is next to nothing to correct: the linear model already tracks the desired
  // response (to the ε nodes' curvature and the initial weights', a tenth of the device's error below)
  EXPECT_LT(train_on_noise(c, o).history.front().jc_val_pct, 0.05);
  o.measure_est = o.measure_val = [&device](const Eigen::VectorXd& v) { return device.simulate(v); };
  const FeedbackTrainingResult r = train_on_noise(c, o);
  const double before = r.history.front().jc_val_pct;
  const ClosedLoopRun run = simulate_closed_loop(r.controller, u_val);  // model mode: the drive the device gets
  const double after = jc_percent(device.simulate(run.v), desired_response(u_val), o.transient_skip);
  EXPECT_GT(before, 0.5) << "the device's saturation must matter at this level";
  EXPECT_LT(after, before / 10.0) << "before " << before << " %, after " << after << " %";
  EXPECT_LT(departure_from_inverse(run, u_val), 0.05);
}

// x(k) = Σ amplitude·sin(2π·f·k/fs + phase) over `tones` ({amplitude, f, phase}), plus `mean`.
Eigen::VectorXd tones(Eigen::Index n, double fs, double mean, const std::vector<std::array<double, 3>>& parts) {
  Eigen::VectorXd x = Eigen::VectorXd::Constant(n, mean);
  for (const auto& [amplitude, f, phase] : parts) {
    for (Eigen::Index k = 0; k < n; ++k) x[k] += amplitude * std::sin(2.0 * std::numbers::pi * f * k / fs + phase);
  }
  return x;
}

// A stretch's harmonic series against closed forms: a mean and harmonics 1..5 of f pass unchanged; a tone
// between two harmonics is removed (every tone here is a multiple of fs/L on the stretch, so the sums are
// exactly orthogonal); samples outside the stretches are untouched; of white noise about (2K+1)/L of the
// power is kept; harmonics at or above fs/2 are not fitted; and a stretch that cannot be is named.
TEST(NeuralFeedbackTest, HarmonicSeriesKeepsTheHarmonicsAndDropsWhatLiesBetween) {
  constexpr double fs = 3000.0, f = 50.0;
  constexpr Eigen::Index n = 2000, start = 100, length = 1200;  // fs/L = 2.5 Hz
  const Eigen::VectorXd harmonic = tones(n, fs, 0.2, {{0.5, f, 0.3}, {0.1, 3 * f, 1.5}, {0.05, 5 * f, 1.0}});
  const Eigen::VectorXd between = tones(n, fs, 0.0, {{0.3, 2.5 * f, 0.7}, {0.2, 7.5 * f, 0.1}});
  const std::vector<HarmonicStretch> stretch{{start, length, f, 5}};
  const Eigen::VectorXd fitted = harmonic_series(harmonic + between, stretch, fs);
  EXPECT_LT((fitted.segment(start, length) - harmonic.segment(start, length)).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_EQ(fitted.head(start), (harmonic + between).head(start));
  EXPECT_EQ(fitted.tail(n - start - length), (harmonic + between).tail(n - start - length));
  // the sixth harmonic is not among the five kept
  const Eigen::VectorXd sixth = tones(n, fs, 0.0, {{0.3, 6 * f, 0.0}});
  EXPECT_LT(harmonic_series(sixth, stretch, fs).segment(start, length).norm(), 1e-10);
  // white noise: 11 components of 1200 samples keep 11/1200 of its power (within a factor of 2 for this draw)
  const Eigen::VectorXd noise = uniform(n, 1.0, 31);
  const double kept = harmonic_series(noise, stretch, fs).segment(start, length).squaredNorm() /
                      noise.segment(start, length).squaredNorm();
  EXPECT_GT(kept, 0.5 * 11.0 / length);
  EXPECT_LT(kept, 2.0 * 11.0 / length);
  // f = 600 Hz at fs = 3000: only 600 and 1200 Hz are below fs/2 (5 components), and 1200 Hz is fitted
  const std::vector<HarmonicStretch> high{{start, length, 600.0, 5}};
  const Eigen::VectorXd second = tones(n, fs, 0.0, {{0.3, 1200.0, 0.4}});
  EXPECT_LT((harmonic_series(second, high, fs) - second).norm(), 1e-10);
  testing_support::expect_invalid([&] { harmonic_series(noise, {{start, 5, 600.0, 5}}, fs); }, "5 components");
  // stretches that cannot be fitted are named
  const HarmonicStretch fine{start, length, f, 5};
  testing_support::expect_invalid([&] { harmonic_series(noise, {fine, {1900, 200, f, 5}}, fs); }, "stretch 1");
  testing_support::expect_invalid([&] { harmonic_series(noise, {{start, length, 1500.0, 5}}, fs); }, "fs/2");
  testing_support::expect_invalid([&] { harmonic_series(noise, {{start, 11, f, 5}}, fs); }, "11 components");
  testing_support::expect_invalid([&] { harmonic_series(noise, {{start, length, f, 0}}, fs); }, "harmonics");
}

// With harmonic stretches the loss counts their error's harmonic series alone: its exact gradient, checked
// against finite differences, with per-sample weights on.
TEST(NeuralFeedbackTest, ClosedLoopGradientOnHarmonicStretchesMatchesFiniteDifferences) {
  NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), saturating_plant());
  initialize_feedback(c, 11, 1.0);
  const Eigen::VectorXd u = uniform(600, 0.9, 5);
  const Eigen::VectorXd y_des = desired_response(u);
  const Eigen::VectorXd w = uniform(600, 1.0, 9).array().abs() * 3.0;
  constexpr double kLambda = 10.0;
  constexpr Eigen::Index kSkip = 20;
  const std::vector<HarmonicStretch> stretches{{100, 200, 75.0, 5}, {350, 240, 120.0, 3}};
  const Eigen::VectorXd g = feedback_gradient(c, u, y_des, kLambda, kSkip, w, 0.0, stretches);
  const Eigen::VectorXd fd = finite_difference(
      c, [&](const NeuralFeedback& x) { return feedback_loss(x, u, y_des, kLambda, kSkip, w, 0.0, stretches); });
  EXPECT_LT((g - fd).norm(), 1e-5 * fd.norm()) << "exact " << g.head(5).transpose() << "\nfd    " << fd.head(5).transpose();
  EXPECT_GT((g - feedback_gradient(c, u, y_des, kLambda, kSkip, w)).norm(), 1e-3 * g.norm())
      << "the stretches change the gradient";
}

// Stepped sines on the saturating plant: four steps of 600 samples at 50, 75, 100 and 150 Hz (fs = 3000),
// each counted from its 100th sample on through its harmonic series.
struct SteppedSines {
  Eigen::VectorXd u;
  Eigen::VectorXd weight;
  std::vector<HarmonicStretch> stretches;
};

SteppedSines stepped_sines(double amplitude) {
  SteppedSines r{Eigen::VectorXd::Zero(2400), Eigen::VectorXd::Zero(2400), {}};
  const std::array<double, 4> f{50.0, 75.0, 100.0, 150.0};
  for (int i = 0; i < 4; ++i) {
    r.u.segment(600 * i, 600) = tones(600, 3000.0, 0.0, {{amplitude, f[i], 0.0}});
    r.stretches.push_back({600 * i + 100, 500, f[i], 5});
    r.weight.segment(600 * i + 100, 500).setOnes();
  }
  return r;
}

// A sensor's noise, many times the power of the saturation's error here, is mostly left out by the harmonic
// stretches: its share of the first J_c falls to about 11/500 of its share sample by sample; and tuned on the
// noisy device the controller still learns most of the saturation's inverse (judged on the quiet device),
// more than tuned on the raw error, though less than tuned on the quiet device (what is left of the noise in
// the 11 components of each stretch is fitted too: playbacks averaged are the cure, design_feedback's).
TEST(NeuralFeedbackTest, HarmonicStretchesLeaveASensorsNoiseOut) {
  const NeuralFeedback c = initialized_controller(linear_plant_model());
  const SteppedSines r = stepped_sines(0.4);
  const Eigen::VectorXd y_des = desired_response(r.u);
  const NarxModel device = saturating_plant();
  const Eigen::VectorXd sensor = uniform(r.u.size(), 0.3, 41);
  const DeviceOutput quiet = [&device](const Eigen::VectorXd& v) { return device.simulate(v); };
  const DeviceOutput noisy = [&](const Eigen::VectorXd& v) { return Eigen::VectorXd(device.simulate(v) + sensor); };
  FeedbackTrainingOptions o;
  o.weight_est = o.weight_val = r.weight;
  o.max_iterations = 0;
  const auto first_jc = [&](const DeviceOutput& measure, bool stretches) {
    FeedbackTrainingOptions first = o;
    first.measure_est = first.measure_val = measure;
    if (stretches) first.harmonic_est = first.harmonic_val = r.stretches;
    return train_feedback(c, r.u, y_des, r.u, y_des, first).history.front().jc_val_pct;
  };
  const double quiet_jc = first_jc(quiet, true);
  EXPECT_GT(quiet_jc, 0.3) << "the saturation must matter";
  // 11 components of 500 samples: the noise's share of J_c falls to about 2 % of what it is sample by sample
  const double raw_share = first_jc(noisy, false) - first_jc(quiet, false);
  const double kept_share = first_jc(noisy, true) - quiet_jc;
  EXPECT_GT(raw_share, 10.0 * quiet_jc) << "the noise must dominate the raw error";
  EXPECT_LT(std::abs(kept_share), 0.06 * raw_share) << kept_share << " of " << raw_share;
  // tuned for 20 iterations, each judged on the quiet device
  o.max_iterations = 20;
  o.harmonic_est = o.harmonic_val = r.stretches;
  const auto tuned_jc = [&](const DeviceOutput& measure) {
    FeedbackTrainingOptions tuning = o;
    tuning.measure_est = tuning.measure_val = measure;
    const NeuralFeedback tuned = train_feedback(c, r.u, y_des, r.u, y_des, tuning).controller;
    return jc_percent(harmonic_series(device.simulate(simulate_closed_loop(tuned, r.u).v), r.stretches, 3000.0),
                      harmonic_series(y_des, r.stretches, 3000.0), 0, r.weight);
  };
  const double on_quiet = tuned_jc(quiet), on_noisy = tuned_jc(noisy);
  o.harmonic_est.clear();
  o.harmonic_val.clear();
  const double on_noisy_raw = tuned_jc(noisy);
  EXPECT_LT(on_quiet, quiet_jc / 10.0);
  EXPECT_LT(on_noisy, quiet_jc / 5.0) << "on the quiet device " << on_quiet << " %";
  EXPECT_LT(on_noisy, 0.8 * on_noisy_raw) << "the noise fitted sample by sample";
}

TEST(NeuralFeedbackTest, ModelFileRoundTripsAndNamesWhatIsWrong) {
  NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), saturating_plant());
  initialize_feedback(c, 3, 1.0);
  c.knee = 0.7;
  const nlohmann::json j = neural_feedback_to_json(c);
  const NeuralFeedback back = neural_feedback_from_json(j);
  EXPECT_EQ(back.net.parameters(), c.net.parameters());
  EXPECT_EQ(back.knee, 0.7);
  EXPECT_EQ(back.structure.ny, 2);
  EXPECT_EQ(std::get<NarxModel>(back.plant.model).net.parameters(), std::get<NarxModel>(c.plant.model).net.parameters());

  const auto broken = [&](auto edit, const std::string& message) {
    nlohmann::json b = j;
    edit(b);
    const std::string what = testing_support::one_line_error<ConfigError>([&] { neural_feedback_from_json(b); });
    EXPECT_NE(what.find(message), std::string::npos) << what;
  };
  broken([](nlohmann::json& b) { b["kind"] = "narx"; }, "model.kind");
  broken([](nlohmann::json& b) { b["params"]["theta"].erase(0); }, "model.params.theta");
  broken([](nlohmann::json& b) { b["params"]["theta"][3] = "x"; }, "model.params.theta[3]");
  broken([](nlohmann::json& b) { b["params"]["knee"] = 1.0; }, "model.params.knee");
  broken([](nlohmann::json& b) { b["params"].erase("nv"); }, "model.params.nv");
  broken([](nlohmann::json& b) { b["params"]["extra"] = 1; }, "extra");
  broken([](nlohmann::json& b) { b.erase("plant"); }, "model.plant");
  broken([](nlohmann::json& b) { b["plant"]["params"]["theta"][0] = nullptr; }, "model.plant.params.theta[0]");
  broken([](nlohmann::json& b) { b["plant"]["fs"] = 48000.0; }, "model.plant.fs");
}

}  // namespace
}  // namespace panelbass::models

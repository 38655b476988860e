// The neural feedback controller with a neural state-space plant model in its loop (loop_plant.h): the
// closed loop against one written out here, the exact closed-loop gradient against finite differences,
// training that corrects a cubic spring, and the controller file with an ss plant.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "dsp/harmonics.h"
#include "dsp/random.h"
#include "dsp/soft_limit.h"
#include "models/control/feedback_training.h"
#include "models/control/loop_plant.h"
#include "models/control/neural_feedback.h"
#include "models/io/config_error.h"
#include "tests/support/expect_error.h"
#include "tests/support/noise.h"
#include "tests/support/ss_models.h"

namespace panelbass::models {
namespace {

constexpr double kFs = 3000.0;

// A scaling that is not the identity, so the units' conversions are exercised.
Scaling odd_scaling() {
  Scaling s;
  s.u_offset = 0.05;
  s.u_scale = 0.9;
  s.y_offset = -0.02;
  s.y_scale = 0.7;
  return s;
}

// A resonance at 100 Hz with a cubic spring, a tanh layer in f and h, and a rest state away from 0.
SsModel nonlinear_ss() { return testing_support::resonant_ss(100.0, kFs, 0.3, 0.1, 0.5, 0.05, 0.02, odd_scaling(), 5); }

FeedbackStructure small_structure() {
  FeedbackStructure s;
  s.nu = 2;
  s.nv = 2;
  s.ny = 3;
  s.hidden = {5};
  return s;
}

// The loop of fig. 7.10 with the ss plant written out from the model's equations (the monomials listed by
// hand): v(k) = soft_limit(u(k) + N1(u(k..k−nu), v(k−1..k−nv), y_s(k−1..k−ny))), then
// y_s(k) = C·x + D·v_s + h, x ← A·x + B·v_s + f, [f; h] = W2·tanh(W1·[x; v_s] + b1) + b2 + P·ζ(x), from the
// encoder's rest state c2 (E·0 = 0, no encoder nodes). Returns v and y (raw).
std::pair<Eigen::VectorXd, Eigen::VectorXd> loop_by_hand(const NeuralFeedback& c, const SsModel& m,
                                                         const Eigen::VectorXd& u) {
  const auto p = ss_parts(m.structure, m.theta.data());
  const Scaling& sc = m.scaling;
  const FeedbackStructure& s = c.structure;
  const Eigen::Index n = u.size();
  Eigen::VectorXd v = Eigen::VectorXd::Zero(n), y_s = Eigen::VectorXd::Zero(n);
  Eigen::Vector2d x = p.c2.col(0);
  Mlp::Workspace ws = c.net.workspace();
  for (Eigen::Index k = 0; k < n; ++k) {
    Eigen::VectorXd r(s.inputs());
    Eigen::Index i = 0;
    for (Eigen::Index j = 0; j <= s.nu; ++j) r[i++] = k - j >= 0 ? u[k - j] : 0.0;
    for (Eigen::Index j = 1; j <= s.nv; ++j) r[i++] = k - j >= 0 ? v[k - j] : 0.0;
    for (Eigen::Index j = 1; j <= s.ny; ++j) r[i++] = k - j >= 0 ? y_s[k - j] : 0.0;
    v[k] = dsp::soft_limit(u[k] + c.net.forward(r, ws), c.knee);
    const double vs = (v[k] - sc.u_offset) / sc.u_scale;
    const Eigen::Vector3d z(x[0], x[1], vs);
    const Eigen::VectorXd nodes = (p.W1 * z + p.b1.col(0)).array().tanh().matrix();
    Eigen::VectorXd zeta(7);
    zeta << x[0] * x[0], x[0] * x[1], x[1] * x[1], x[0] * x[0] * x[0], x[0] * x[0] * x[1], x[0] * x[1] * x[1],
        x[1] * x[1] * x[1];
    const Eigen::Vector3d fh = p.W2 * nodes + p.b2.col(0) + p.P * zeta;
    y_s[k] = p.C.row(0).dot(x) + p.D(0, 0) * vs + fh[2];
    x = p.A * x + p.B.col(0) * vs + fh.head(2);
  }
  return {v, (y_s.array() * sc.y_scale + sc.y_offset).matrix()};
}

TEST(LoopPlantTest, RunnerAndClosedLoopWithAnSsPlantMatchTheLoopWrittenOut) {
  const SsModel m = nonlinear_ss();
  NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), m);
  initialize_feedback(c, 7, 1.0);
  const Eigen::VectorXd u = testing_support::uniform_noise(600, 0.7, 4);
  const auto [v, y] = loop_by_hand(c, m, u);
  ASSERT_GT(y.cwiseAbs().maxCoeff(), 0.1) << "the plant must be driven";
  const ClosedLoopRun run = simulate_closed_loop(c, u);
  EXPECT_LT((run.v - v).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((run.y - y).cwiseAbs().maxCoeff(), 1e-12);
  FeedbackRunner runner(c);
  for (int pass = 0; pass < 2; ++pass) {  // the second pass checks reset()
    for (Eigen::Index k = 0; k < u.size(); ++k) {
      ASSERT_NEAR(runner.control(u[k]), v[k], 1e-12) << k;
      const double yk = runner.plant_model_output();
      runner.push_output(yk);
      ASSERT_NEAR(yk, y[k], 1e-12) << k;
    }
    runner.reset();
  }
  // N1 = 0: the loop is the plant model's own free run (from the same rest state)
  const NeuralFeedback open = NeuralFeedback::with_structure(small_structure(), m);
  const ClosedLoopRun through = simulate_closed_loop(open, u);
  EXPECT_LT((through.y - m.simulate(through.v)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(LoopPlantTest, ClosedLoopGradientThroughAnSsPlantMatchesFiniteDifferences) {
  const SsModel m = nonlinear_ss();
  NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), m);
  initialize_feedback(c, 11, 1.0);
  const Eigen::VectorXd u = testing_support::uniform_noise(400, 0.9, 5);  // loud enough for the rail penalty
  // the target: the plant's linear part (the cubic and the network removed) on u
  SsModel linear = m;
  auto lp = ss_parts(linear.structure, linear.theta.data());
  lp.P.setZero();
  lp.W2.setZero();
  lp.b2.setZero();
  const Eigen::VectorXd y_des = linear.simulate(u);
  constexpr double kLambda = 10.0, kDc = 0.5;
  constexpr Eigen::Index kSkip = 10;
  const ClosedLoopRun run = simulate_closed_loop(c, u);
  ASSERT_GT((run.s.array().abs() > c.knee).count(), 10) << "the rail penalty must be exercised";
  const Eigen::VectorXd g = feedback_gradient(c, u, y_des, kLambda, kSkip, {}, kDc);
  constexpr double h = 1e-6;
  Eigen::VectorXd fd(g.size());
  for (Eigen::Index i = 0; i < fd.size(); ++i) {
    NeuralFeedback plus = c, minus = c;
    plus.net.parameters()[i] += h;
    minus.net.parameters()[i] -= h;
    fd[i] = (feedback_loss(plus, u, y_des, kLambda, kSkip, {}, kDc) - feedback_loss(minus, u, y_des, kLambda, kSkip, {}, kDc)) /
            (2 * h);
  }
  EXPECT_LT((g - fd).norm(), 1e-6 * fd.norm()) << "exact " << g.head(5).transpose() << "\nfd    " << fd.head(5).transpose();
}

// Sine steps of 250 samples at log-uniform random frequencies in 30–150 Hz and amplitudes in 0.2–0.6, faded.
Eigen::VectorXd stepped_sines(Eigen::Index n, std::uint64_t seed) {
  dsp::Rng rng(seed);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(n);
  constexpr Eigen::Index kStep = 250, kFade = 40;
  for (Eigen::Index start = 0; start + kStep <= n; start += kStep) {
    const double f = 30.0 * std::pow(5.0, rng.uniform(0.0, 1.0)), a = rng.uniform(0.2, 0.6);
    for (Eigen::Index k = 0; k < kStep; ++k) {
      const double edge = static_cast<double>(std::min(k, kStep - 1 - k));
      const double fade = edge < kFade ? 0.5 - 0.5 * std::cos(std::numbers::pi * edge / kFade) : 1.0;
      u[start + k] = fade * a * std::sin(2.0 * std::numbers::pi * f * static_cast<double>(k) / kFs);
    }
  }
  return u;
}

// THD (percent) and fundamental of the last 1500 samples (50 periods of 100 Hz) of y.
dsp::HarmonicLevels tail_levels(const Eigen::VectorXd& y, double f) { return dsp::harmonic_levels(y.tail(1500), kFs, f, 5); }

TEST(LoopPlantTest, TrainingThroughAnSsPlantCorrectsItsCubic) {
  // A lightly damped resonance at 100 Hz driven through a force that saturates (f's cubic of the drive, 11 %
  // of the linear term at 0.6); the target is its linear part.
  const SsModel plant = testing_support::resonant_ss(100.0, kFs, 0.1, 0.0, 0.05, 0.0, 0.0, Scaling{}, 1, true);
  SsModel linear = plant;
  ss_parts(linear.structure, linear.theta.data()).P.setZero();
  NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), plant);
  initialize_feedback(c, 3);
  const Eigen::VectorXd u_est = stepped_sines(2500, 1), u_val = stepped_sines(2500, 2);
  FeedbackTrainingOptions o;
  o.max_iterations = 40;
  o.transient_skip = 20;
  const FeedbackTrainingResult r = train_feedback(c, u_est, linear.simulate(u_est), u_val, linear.simulate(u_val), o);
  const double before = r.history.front().jc_val_pct, after = best_validation_jc_pct(r);
  EXPECT_LT(after, 0.5 * before) << "validation J_c " << before << " % -> " << after << " %";

  // A 50 Hz probe (its third harmonic at 150 Hz, near the resonance): THD of the corrected loop, and of the
  // plant alone driven to the same output fundamental (its drive scaled until the fundamentals agree)
  constexpr double kProbe = 50.0;
  Eigen::VectorXd sine(3000);
  for (Eigen::Index k = 0; k < sine.size(); ++k) sine[k] = 0.5 * std::sin(2.0 * std::numbers::pi * kProbe * k / kFs);
  const dsp::HarmonicLevels with = tail_levels(simulate_closed_loop(r.controller, sine).y, kProbe);
  double gain = 1.0;
  dsp::HarmonicLevels without = tail_levels(plant.simulate(sine), kProbe);
  for (int i = 0; i < 20; ++i) {
    gain *= with.amplitude[0] / without.amplitude[0];
    without = tail_levels(plant.simulate(gain * sine), kProbe);
  }
  ASSERT_NEAR(without.amplitude[0], with.amplitude[0], 1e-6 * with.amplitude[0]);
  EXPECT_LT(with.thd_percent(), 0.5 * without.thd_percent())
      << "THD with " << with.thd_percent() << " %, without " << without.thd_percent() << " % (drive x" << gain << ")";
}

TEST(LoopPlantTest, ControllerFileWithAnSsPlantRoundTripsAndNamesWhatIsWrong) {
  const SsModel m = nonlinear_ss();
  NeuralFeedback c = NeuralFeedback::with_structure(small_structure(), m);
  initialize_feedback(c, 3, 1.0);
  const nlohmann::json j = neural_feedback_to_json(c);
  EXPECT_EQ(j["plant"]["kind"], "ss");
  const NeuralFeedback back = neural_feedback_from_json(j);
  ASSERT_TRUE(std::holds_alternative<SsModel>(back.plant.model));
  EXPECT_EQ(std::get<SsModel>(back.plant.model).theta, m.theta);
  EXPECT_EQ(back.net.parameters(), c.net.parameters());
  const Eigen::VectorXd u = testing_support::uniform_noise(300, 0.6, 9);
  EXPECT_EQ(simulate_closed_loop(back, u).y, simulate_closed_loop(c, u).y);

  const auto broken = [&](auto edit, const std::string& message) {
    nlohmann::json b = j;
    edit(b);
    const std::string what = testing_support::one_line_error<ConfigError>([&] { neural_feedback_from_json(b); });
    EXPECT_NE(what.find(message), std::string::npos) << what;
  };
  broken([](nlohmann::json& b) { b["plant"]["fs"] = 48000.0; }, "model.plant.fs");
  broken([](nlohmann::json& b) { b["plant"]["kind"] = "linear"; }, "model.plant.kind");
  broken([](nlohmann::json& b) { b["plant"].erase("kind"); }, "model.plant.kind");
  broken([](nlohmann::json& b) { b["plant"]["params"]["theta"].erase(0); }, "model.plant.params.theta");
  broken([](nlohmann::json& b) { b["plant"]["params"]["states"] = 0; }, "model.plant.params.states");
}

}  // namespace
}  // namespace panelbass::models

// Multiple shooting for NARX training against independent expectations: the stacked gradient (θ, the free
// initial histories and the continuity penalty) against central differences of the stacked loss; the
// Gauss–Newton matrix against central differences of that gradient where every residual is 0; the loss's
// value by its definition; a known NARX recovered from noise-free data to near machine precision by pem then
// oem-ms; oem-ms below single shooting from the same start on a lightly damped system; the named errors.
#include "models/narx/narx_multiple_shooting.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "dsp/excitation.h"
#include "models/narx/narx_training.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

/// A NARX model with [5F] initial weights drawn from `seed`.
NarxModel shooting_model(int na, int nb, int nk, std::vector<int> hidden, std::uint64_t seed) {
  NarxModel m = NarxModel::with_structure({na, nb, nk, std::move(hidden)}, Scaling{}, 1000.0);
  m.net.initialize(1.0, seed);
  return m;
}

/// dV/dz by central differences of MultipleShooting::loss over z = [θ; histories].
Eigen::VectorXd stacked_central_differences(MultipleShooting& ms, const NarxModel& model, double h) {
  NarxModel probe = model;
  Eigen::VectorXd histories = ms.histories();
  const Eigen::Index P = model.net.parameter_count();
  Eigen::VectorXd g(P + histories.size());
  for (Eigen::Index p = 0; p < g.size(); ++p) {
    double& entry = p < P ? probe.net.parameters()[p] : histories[p - P];
    const double keep = entry;
    entry = keep + h;
    const double plus = ms.loss(probe, histories);
    entry = keep - h;
    const double minus = ms.loss(probe, histories);
    entry = keep;
    g[p] = (plus - minus) / (2.0 * h);
  }
  return g;
}

/// max_p |a_p − b_p| / max(|b|∞, tiny).
double relative_error(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(b.cwiseAbs().maxCoeff(), 1e-300);
}

TEST(NarxMultipleShootingGradient, MatchesCentralDifferencesOverWeightsHistoriesAndPenalty) {
  // Two layers, a delay and past inputs; weights, a penalty ρ = 3 and histories away from continuity, so every
  // part of the stacked loss has a gradient of its own.
  const NarxModel model = shooting_model(3, 2, 1, {4, 3}, 5);
  const Eigen::VectorXd u = dsp::uniform_noise(90, 1.0, 3);
  const Eigen::VectorXd y = model.simulate_scaled(u) + 0.1 * dsp::uniform_noise(90, 1.0, 4);
  Eigen::VectorXd w = 0.5 * Eigen::VectorXd::Ones(90) + 0.4 * dsp::uniform_noise(90, 1.0, 6);
  MultipleShooting ms(model, u, y, 5, {.window = 20, .penalty = 3.0}, w);
  ASSERT_EQ(ms.windows(), 4);  // 85 samples: 20, 20, 20 and the remainder 25
  EXPECT_EQ(ms.window_start(3), 65);
  EXPECT_EQ(ms.window_start(4), 90);
  ms.histories() += 0.05 * dsp::uniform_noise(static_cast<std::size_t>(ms.histories().size()), 1.0, 8);
  Eigen::VectorXd g;
  Eigen::MatrixXd H;
  ms.gradient(model, ms.histories(), g, &H);
  const Eigen::VectorXd fd = stacked_central_differences(ms, model, 1e-6);
  EXPECT_LT(relative_error(g, fd), 1e-6) << "analytic\n" << g.transpose() << "\nnumeric\n" << fd.transpose();
  // The history part alone is not small: the test sees it.
  EXPECT_GT(g.tail(ms.histories().size()).cwiseAbs().maxCoeff(), 1e-3 * g.cwiseAbs().maxCoeff());
}

TEST(NarxMultipleShootingGradient, LossIsTheDefinitionsSumOfWindowErrorsAndContinuity) {
  // V by hand: simulate each window from its history with the model's own one-step map, add ρ·‖c‖².
  const NarxModel model = shooting_model(2, 1, 0, {3}, 2);
  const Eigen::VectorXd u = dsp::uniform_noise(40, 1.0, 1);
  const Eigen::VectorXd y = dsp::uniform_noise(40, 1.0, 2);
  MultipleShooting ms(model, u, y, 0, {.window = 10, .penalty = 2.0});
  ms.histories()[3] += 0.3;
  double sum = 0.0;
  Eigen::VectorXd x(4);
  Mlp::Workspace ws = model.net.workspace();
  std::vector<double> previous_end;
  for (Eigen::Index w = 0; w < ms.windows(); ++w) {
    std::vector<double> out{ms.histories()[2 * w + 1], ms.histories()[2 * w]};  // ŷ(s−2), ŷ(s−1)
    if (w > 0) {
      for (std::size_t i = 0; i < 2; ++i) {
        sum += 2.0 * std::pow(ms.histories()[2 * w + static_cast<Eigen::Index>(i)] - previous_end[i], 2);
      }
    }
    for (Eigen::Index k = ms.window_start(w); k < ms.window_start(w + 1); ++k) {
      x << out[out.size() - 1], out[out.size() - 2], u[k], k >= 1 ? u[k - 1] : 0.0;
      out.push_back(model.net.forward(x, ws));
      sum += std::pow(out.back() - y[k], 2);
    }
    previous_end = {out[out.size() - 1], out[out.size() - 2]};
  }
  EXPECT_NEAR(ms.loss(model, ms.histories()), 0.5 * sum / 40.0, 1e-14);
}

TEST(NarxMultipleShootingGradient, GaussNewtonMatrixIsTheHessianWhereEveryResidualIsZero) {
  // Data from the model itself and histories at its own outputs: every residual is 0, so the Hessian of V is
  // exactly JᵀJ/Σw, the matrix LM steps with; compare with central differences of the analytic gradient.
  const NarxModel model = shooting_model(2, 2, 0, {3}, 9);
  const Eigen::VectorXd u = dsp::uniform_noise(60, 1.0, 5);
  const Eigen::VectorXd y = model.simulate_scaled(u);
  MultipleShooting ms(model, u, y, 4, {.window = 14, .penalty = 5.0});
  Eigen::VectorXd g;
  Eigen::MatrixXd H;
  EXPECT_LT(ms.gradient(model, ms.histories(), g, &H), 1e-30);
  const Eigen::Index P = model.net.parameter_count(), n = g.size();
  Eigen::MatrixXd fd(n, n);
  NarxModel probe = model;
  Eigen::VectorXd histories = ms.histories(), g_plus, g_minus;
  constexpr double h = 1e-5;
  for (Eigen::Index p = 0; p < n; ++p) {
    double& entry = p < P ? probe.net.parameters()[p] : histories[p - P];
    const double keep = entry;
    entry = keep + h;
    ms.gradient(probe, histories, g_plus, nullptr);
    entry = keep - h;
    ms.gradient(probe, histories, g_minus, nullptr);
    entry = keep;
    fd.col(p) = (g_plus - g_minus) / (2.0 * h);
  }
  EXPECT_LT((H - fd).cwiseAbs().maxCoeff() / H.cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((H - H.transpose()).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(NarxMultipleShootingTraining, RecoversAKnownNarxFromNoiseFreeDataToNearMachinePrecision) {
  // A NARX 2-2-2 teacher; the student starts from its weights with up to 10 % relative errors (from other [5F]
  // weights LM crawls towards a permutation of the teacher, in every mode); oem-ms alone by LM. The penalty
  // grows ×2 a step to 1e3; far beyond that (1e6) the stack's conditioning slows LM's last digits.
  const NarxModel teacher = shooting_model(2, 2, 0, {2}, 22);
  const Eigen::VectorXd u = dsp::uniform_noise(1200, 1.0, 13), uv = dsp::uniform_noise(600, 1.0, 14);
  const Eigen::VectorXd y = teacher.simulate_scaled(u), yv = teacher.simulate_scaled(uv);
  NarxModel start = teacher;
  start.net.parameters().array() *=
      1.0 + 0.1 * dsp::uniform_noise(static_cast<std::size_t>(teacher.net.parameter_count()), 1.0, 17).array();
  TrainingOptions o;
  o.modes = {TrainingMode::oem_ms};
  o.max_iterations = 100;
  o.multiple_shooting = {.window = 100, .penalty = 1.0, .penalty_growth = 2.0, .penalty_max = 1e3};
  const double j_start = j_percent(start.simulate_scaled(uv), yv, 4);
  const TrainingResult r = train_narx(start, u, y, uv, yv, o);
  EXPECT_GT(j_start, 1e-2);
  EXPECT_LT(r.history.back().j_val_pct, 1e-24);  // J in percent: an amplitude error near 1e-13 of the output's
  EXPECT_LT(j_percent(r.model.simulate_scaled(uv), yv, 4), 1e-24);
  EXPECT_LT((r.model.net.parameters() - teacher.net.parameters()).cwiseAbs().maxCoeff(), 1e-9);
}

/// [5Q] y(k) = 2A·cos(23°)·y(k−1) − A²·y(k−2) + u(k), scaled so that max |y| = 1 over the whole record.
Eigen::VectorXd lightly_damped_second_order(const Eigen::VectorXd& u, double A) {
  const double c = 2.0 * A * std::cos(23.0 * 3.14159265358979323846 / 180.0);
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    y[k] = u[k] + (k >= 1 ? c * y[k - 1] : 0.0) - (k >= 2 ? A * A * y[k - 2] : 0.0);
  }
  return y / y.cwiseAbs().maxCoeff();
}

TEST(NarxMultipleShootingTraining, WindowsFirstReachALowerJThanSingleShootingFromTheSameStart) {
  // The thesis's A = 0.99 point (poles 0.99·e^{±j23°}), NN 3-5-1 from the [5F] weights of seed 4, no pem: oem-d
  // alone from that random start ends at J_val 20 %, oem-ms then oem-d from the same start at 0.0045 % (the
  // windows' short simulations from measured histories bring θ near the system; the free run then polishes).
  // Not so from every start: of seeds 1–5 the windows win on 1 (0.0004 against 0.0026 %) and 4, lose on 2 and
  // 5, and neither finds the system from 3 (docs/identification.md, "Multiple shooting").
  const Eigen::VectorXd u_all = dsp::uniform_noise(5000, 1.0, 7);
  const Eigen::VectorXd y_all = lightly_damped_second_order(u_all, 0.99);
  const Eigen::VectorXd u = u_all.head(3000), y = y_all.head(3000), uv = u_all.tail(2000), yv = y_all.tail(2000);
  const NarxModel start = shooting_model(2, 0, 0, {5}, 4);
  TrainingOptions o;
  o.max_iterations = 200;
  o.init = 50;
  o.modes = {TrainingMode::oem_d};
  const double single = j_percent(train_narx(start, u, y, uv, yv, o).model.simulate_scaled(uv, yv, 50), yv, 50);
  o.modes = {TrainingMode::oem_ms, TrainingMode::oem_d};
  o.multiple_shooting.window = 100;
  const TrainingResult windows_first = train_narx(start, u, y, uv, yv, o);
  const double shooting = j_percent(windows_first.model.simulate_scaled(uv, yv, 50), yv, 50);
  EXPECT_GT(single, 1.0);
  EXPECT_LT(shooting, 1e-3 * single) << "oem-d alone " << single << " %, oem-ms then oem-d " << shooting << " %";
}

TEST(NarxMultipleShootingTraining, ErrorsNameTheOption) {
  const NarxModel model = shooting_model(8, 2, 0, {3}, 1);
  const Eigen::VectorXd u = dsp::uniform_noise(300, 1.0, 1), y = model.simulate_scaled(u);
  const auto message = [&](const TrainingOptions& o) {
    try {
      train_narx(model, u, y, Eigen::VectorXd(), Eigen::VectorXd(), o);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  TrainingOptions o;
  o.modes = {TrainingMode::oem_ms};
  o.multiple_shooting.window = 5;  // < na = 8
  EXPECT_NE(message(o).find("multiple-shooting window must be ≥ max(na, 1) = 8"), std::string::npos) << message(o);
  o.multiple_shooting = {.window = 50, .penalty = 0.0};
  EXPECT_NE(message(o).find("penalty must be a finite number > 0"), std::string::npos) << message(o);
  o.multiple_shooting = {.window = 50, .penalty = 1.0, .penalty_growth = 0.5};
  EXPECT_NE(message(o).find("penalty growth must be a finite number ≥ 1"), std::string::npos) << message(o);
  o.multiple_shooting = {.window = 50, .penalty = 10.0, .penalty_growth = 1.0, .penalty_max = 1.0};
  EXPECT_NE(message(o).find("penalty maximum must be finite and ≥ the penalty"), std::string::npos) << message(o);
  o.multiple_shooting = {.window = 400};
  EXPECT_NE(message(o).find("oem-ms needs a window of 400 samples"), std::string::npos) << message(o);
  o.multiple_shooting = {};
  o.optimizer = Optimizer::sd;
  EXPECT_NE(message(o).find("oem-ms (multiple shooting) needs --optimizer lm, got sd"), std::string::npos)
      << message(o);
  EXPECT_THROW(loss_gradient(model, u, y, TrainingMode::oem_ms, 16), std::invalid_argument);
  EXPECT_EQ(parse_training_mode("oem-ms"), TrainingMode::oem_ms);
  EXPECT_EQ(to_string(TrainingMode::oem_ms), "oem-ms");
}

}  // namespace
}  // namespace panelbass::models

// NARX training (thesis ch. 5–6) against independent expectations: the dynamic gradient [5L] and the PEM
// gradient [5K] against central differences of the loss; fig. 5.16 (the static gradient of OEM_s is far
// too small at A = 0.98); a reduced table 5.1; the 3-tanh static example of ch. 5 with small and large
// initial weights; early stopping on validation data (fig. 6.4); history, [5C] steps and the errors.
#include "models/narx/narx_training.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "dsp/excitation.h"
#include "dsp/random.h"
#include "models/optimization/evidence_decay.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

/// The second-order system of [5Q]: poles A·e^{±j23°}, y(k) = 2A·cos(23°)·y(k−1) − A²·y(k−2) + b·u(k),
/// with b chosen so that max |y| = 1 (the thesis's scaled units).
Eigen::VectorXd second_order(const Eigen::VectorXd& u, double A) {
  const double c = 2.0 * A * std::cos(23.0 * std::numbers::pi / 180.0);
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    double s = u[k];
    if (k >= 1) s += c * y[k - 1];
    if (k >= 2) s -= A * A * y[k - 2];
    y[k] = s;
  }
  return y / y.cwiseAbs().maxCoeff();
}

/// A model of the given structure with [5F] initial weights for inputs in ±input_max.
NarxModel initial_model(int na, int nb, int nk, std::vector<int> hidden, std::uint64_t seed, double input_max = 1.0,
                        double scale = 1.0) {
  NarxStructure s;
  s.na = na;
  s.nb = nb;
  s.nk = nk;
  s.hidden = std::move(hidden);
  NarxModel m = NarxModel::with_structure(s, Scaling{}, 1000.0);
  m.net.initialize(input_max, seed, scale);
  return m;
}

TrainingOptions options_for(std::vector<TrainingMode> modes, Optimizer optimizer, int iterations) {
  TrainingOptions o;
  o.modes = std::move(modes);
  o.optimizer = optimizer;
  o.max_iterations = iterations;
  o.early_stopping = false;
  return o;
}

/// Central differences of training_loss (weighted by `weights`, empty = 1): (V(θ + h·e_p) − V(θ − h·e_p)) / 2h,
/// for every p.
Eigen::VectorXd central_differences(const NarxModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                    TrainingMode mode, Eigen::Index skip, double h,
                                    const Eigen::VectorXd& weights = Eigen::VectorXd()) {
  NarxModel probe = model;
  Eigen::VectorXd g(model.net.parameter_count());
  for (Eigen::Index p = 0; p < g.size(); ++p) {
    const double keep = probe.net.parameters()[p];
    probe.net.parameters()[p] = keep + h;
    const double plus = training_loss(probe, u, y, mode, skip, weights);
    probe.net.parameters()[p] = keep - h;
    const double minus = training_loss(probe, u, y, mode, skip, weights);
    probe.net.parameters()[p] = keep;
    g[p] = (plus - minus) / (2.0 * h);
  }
  return g;
}

/// Largest per-parameter error relative to max(|reference_p|, floor·‖reference‖∞): the floor keeps
/// parameters whose true gradient is nearly zero from dividing by (almost) nothing.
double worst_relative_error(const Eigen::VectorXd& g, const Eigen::VectorXd& reference, double floor = 1e-3) {
  const double scale = reference.cwiseAbs().maxCoeff();
  double worst = 0.0;
  for (Eigen::Index p = 0; p < g.size(); ++p) {
    const double denominator = std::max(std::abs(reference[p]), floor * scale);
    worst = std::max(worst, std::abs(g[p] - reference[p]) / denominator);
  }
  return worst;
}

/// A NARX 3-3-1 (na = 2, nb = 0) after a few PEM iterations on the damped system A = 0.9: a realistic
/// point where the fed-back outputs matter.
struct DampedCase {
  Eigen::VectorXd u = dsp::uniform_noise(500, 1.0, 101);
  Eigen::VectorXd y = second_order(u, 0.9);
  NarxModel model = initial_model(2, 0, 0, {3}, 7);
  DampedCase() {
    model = train_narx(model, u, y, {}, {}, options_for({TrainingMode::pem}, Optimizer::lm, 4)).model;
  }
};

// ----- gradients ---------------------------------------------------------------------------------

TEST(NarxTrainingGradient, OemDynamicMatchesCentralDifferencesOfTheSimulationLoss) {
  DampedCase c;
  for (const Eigen::Index skip : {Eigen::Index{0}, Eigen::Index{25}}) {
    const Eigen::VectorXd dynamic = loss_gradient(c.model, c.u, c.y, TrainingMode::oem_d, skip);
    const Eigen::VectorXd fd = central_differences(c.model, c.u, c.y, TrainingMode::oem_d, skip, 1e-5);
    ASSERT_EQ(dynamic.size(), c.model.net.parameter_count());
    EXPECT_LT(worst_relative_error(dynamic, fd), 1e-6) << "skip " << skip;
  }
}

TEST(NarxTrainingGradient, OemDynamicMatchesCentralDifferencesWithTwoLayersDelayAndPastInputs) {
  // NN 4-4-3-1: na = 2, nb = 1, nk = 1 — every index of the regressor and both hidden layers.
  const Eigen::VectorXd u = dsp::uniform_noise(400, 1.0, 102);
  Eigen::VectorXd y = second_order(u, 0.85);
  y = (y.array() + 0.2 * y.array().square()).matrix();  // a mild even nonlinearity
  const NarxModel model = initial_model(2, 1, 1, {4, 3}, 8);
  const Eigen::VectorXd dynamic = loss_gradient(model, u, y, TrainingMode::oem_d, 6);
  const Eigen::VectorXd fd = central_differences(model, u, y, TrainingMode::oem_d, 6, 1e-5);
  EXPECT_LT(worst_relative_error(dynamic, fd), 1e-6);
}

TEST(NarxTrainingGradient, OemDynamicFromMeasuredOutputsMatchesCentralDifferences) {
  // The state set by the first 30 measured outputs (ŷ(k) = y(k), k < 30), then free run: [5L] starts there.
  DampedCase c;
  constexpr Eigen::Index init = 30;
  const Eigen::VectorXd dynamic = loss_gradient(c.model, c.u, c.y, TrainingMode::oem_d, init, 1e-6, {}, init);
  NarxModel probe = c.model;
  Eigen::VectorXd fd(dynamic.size());
  for (Eigen::Index p = 0; p < fd.size(); ++p) {
    const double keep = probe.net.parameters()[p], h = 1e-5;
    probe.net.parameters()[p] = keep + h;
    const double plus = training_loss(probe, c.u, c.y, TrainingMode::oem_d, init, {}, init);
    probe.net.parameters()[p] = keep - h;
    const double minus = training_loss(probe, c.u, c.y, TrainingMode::oem_d, init, {}, init);
    probe.net.parameters()[p] = keep;
    fd[p] = (plus - minus) / (2.0 * h);
  }
  EXPECT_LT(worst_relative_error(dynamic, fd), 1e-6);
  // and the loss is the one of the simulation validate --init runs: 1/(2(N − init))·Σ_{k≥init} e²
  const Eigen::VectorXd y_sim = c.model.simulate_scaled(c.u, c.y, init);
  const Eigen::Index M = c.u.size() - init;
  EXPECT_NEAR(training_loss(c.model, c.u, c.y, TrainingMode::oem_d, init, {}, init),
              0.5 * (y_sim - c.y).tail(M).squaredNorm() / static_cast<double>(M), 1e-15);
}

TEST(NarxTrainingGradient, PemMatchesCentralDifferencesOfThePredictionLoss) {
  DampedCase c;
  const Eigen::VectorXd pem = loss_gradient(c.model, c.u, c.y, TrainingMode::pem, 4);
  const Eigen::VectorXd fd = central_differences(c.model, c.u, c.y, TrainingMode::pem, 4, 1e-5);
  EXPECT_LT(worst_relative_error(pem, fd), 1e-6);
}

TEST(NarxTrainingGradient, OemNumericAgreesWithDynamic) {
  DampedCase c;
  const Eigen::VectorXd numeric = loss_gradient(c.model, c.u, c.y, TrainingMode::oem_n, 4, 1e-5);
  const Eigen::VectorXd dynamic = loss_gradient(c.model, c.u, c.y, TrainingMode::oem_d, 4);
  EXPECT_LT(worst_relative_error(numeric, dynamic), 1e-6);
}

TEST(NarxTrainingGradient, WithoutFedBackOutputsAllGradientsCoincide) {
  // na = 0: no output is fed back, so [5L] reduces to [5K] and simulation equals prediction.
  const Eigen::VectorXd u = dsp::uniform_noise(300, 1.0, 103);
  const Eigen::VectorXd y = (u.array().tanh() + 0.3 * u.array().square()).matrix();
  const NarxModel model = initial_model(0, 2, 0, {4}, 9);
  const Eigen::VectorXd pem = loss_gradient(model, u, y, TrainingMode::pem, 2);
  EXPECT_LT((loss_gradient(model, u, y, TrainingMode::oem_s, 2) - pem).norm(), 1e-14 * pem.norm());
  EXPECT_LT((loss_gradient(model, u, y, TrainingMode::oem_d, 2) - pem).norm(), 1e-14 * pem.norm());
  EXPECT_DOUBLE_EQ(training_loss(model, u, y, TrainingMode::pem, 2), training_loss(model, u, y, TrainingMode::oem_d, 2));
}

TEST(NarxTrainingLoss, IsHalfTheMeanSquaredErrorOfTheModelsOwnSimulationAndPrediction) {
  DampedCase c;
  const Eigen::Index skip = 10, M = c.u.size() - skip;
  // [5N] V = 1/(2(N−skip))·Σ_{k≥skip} e(k)², with NarxModel's own simulation (OEM) and prediction (PEM)
  const Eigen::VectorXd sim = c.model.simulate_scaled(c.u);
  const Eigen::VectorXd pred = c.model.predict_scaled(c.u, c.y);
  const double v_oem = 0.5 * (sim - c.y).tail(M).squaredNorm() / static_cast<double>(M);
  const double v_pem = 0.5 * (pred - c.y).tail(M).squaredNorm() / static_cast<double>(M);
  EXPECT_NEAR(training_loss(c.model, c.u, c.y, TrainingMode::oem_d, skip), v_oem, 1e-14);
  EXPECT_NEAR(training_loss(c.model, c.u, c.y, TrainingMode::oem_s, skip), v_oem, 1e-14);
  EXPECT_NEAR(training_loss(c.model, c.u, c.y, TrainingMode::pem, skip), v_pem, 1e-14);
  EXPECT_GT(v_oem, v_pem);  // simulation errors accumulate; prediction errors do not
}

// ----- fig. 5.16 ---------------------------------------------------------------------------------

TEST(NarxTrainingFig516, StaticGradientIsFarTooSmallWhereTheDynamicOneIsRight) {
  // [5Q] A = 0.98, NN 3-5-1 with inputs y(k−1), y(k−2), u(k), after a short PEM training (the thesis's
  // steepest descent: α = 0.1, L = 1). The thesis finds 2.5e-4 (static) against 2.6 (from the error surface).
  const Eigen::VectorXd u = dsp::uniform_noise(2000, 1.0, 7);
  const Eigen::VectorXd y = second_order(u, 0.98);
  TrainingOptions pem = options_for({TrainingMode::pem}, Optimizer::sd, 10);
  pem.step = 0.1;
  pem.batch = 1;
  const NarxModel model = train_narx(initial_model(2, 0, 0, {5}, 11), u, y, {}, {}, pem).model;
  const Eigen::Index skip = 4;

  const Eigen::VectorXd fd = central_differences(model, u, y, TrainingMode::oem_d, skip, 1e-6);
  const Eigen::VectorXd dynamic = loss_gradient(model, u, y, TrainingMode::oem_d, skip);
  const Eigen::VectorXd stat = loss_gradient(model, u, y, TrainingMode::oem_s, skip);
  EXPECT_LT(worst_relative_error(dynamic, fd), 1e-5);
  // at least one parameter (and a clearly non-zero true gradient) where the static gradient is ≥ 100× too small
  double largest_ratio = 0.0;
  for (Eigen::Index p = 0; p < fd.size(); ++p) {
    if (std::abs(fd[p]) < 1e-2 * fd.cwiseAbs().maxCoeff()) continue;
    largest_ratio = std::max(largest_ratio, std::abs(fd[p]) / std::max(std::abs(stat[p]), 1e-300));
  }
  EXPECT_GE(largest_ratio, 100.0);
}

// ----- table 5.1 ---------------------------------------------------------------------------------

TEST(NarxTrainingTable51, PemAndOemDynamicFindTheSystemOemStaticFailsAsPolesNearTheUnitCircle) {
  // Reduced table 5.1 (the full table is bench/narx_table51_bench.cpp). The thesis's steps: PEM with
  // L = 1, α = 0.1 (10 iterations) and L = N, α = 0.01 (20); then from that PEM model OEM_s with L = N,
  // α = 0.01 (20), and here also OEM_d with Levenberg–Marquardt. The thesis's J_OEMs: 0.2, 0.8, 8.0 %.
  const std::array<double, 3> poles{0.8, 0.95, 0.99};
  std::array<double, 3> j_oem_s{};
  for (std::size_t i = 0; i < poles.size(); ++i) {
    const double A = poles[i];
    const Eigen::VectorXd u = dsp::uniform_noise(2000, 1.0, 7);
    const Eigen::VectorXd y = second_order(u, A);
    const NarxModel start = initial_model(2, 0, 0, {5}, 11);
    const Eigen::Index skip = 4;

    TrainingOptions sd = options_for({TrainingMode::pem}, Optimizer::sd, 10);
    sd.step = 0.1;
    sd.batch = 1;
    NarxModel pem = train_narx(start, u, y, {}, {}, sd).model;
    sd.step = 0.01;
    sd.batch = 0;
    sd.max_iterations = 20;
    pem = train_narx(pem, u, y, {}, {}, sd).model;
    const double j_pem_pred = j_percent(pem.predict_scaled(u, y), y, skip);
    EXPECT_LT(j_pem_pred, 0.1) << "A = " << A;

    // PEM with LM from the same start: the prediction optimum is easy to find (the thesis's 0.01 %)
    const TrainingResult pem_lm = train_narx(start, u, y, {}, {}, options_for({TrainingMode::pem}, Optimizer::lm, 30));
    EXPECT_LT(j_percent(pem_lm.model.predict_scaled(u, y), y, skip), 0.01) << "A = " << A;

    sd.modes = {TrainingMode::oem_s};
    const TrainingResult oem_s = train_narx(pem, u, y, {}, {}, sd);
    j_oem_s[i] = oem_s.history.back().j_est_pct;

    const TrainingResult oem_d = train_narx(pem, u, y, {}, {}, options_for({TrainingMode::oem_d}, Optimizer::lm, 100));
    const double j_oem_d = oem_d.history.back().j_est_pct;
    // the simulation reaches the accuracy PEM has in prediction
    EXPECT_LE(j_oem_d, 2.0 * j_pem_pred + 0.01) << "A = " << A;
    EXPECT_NEAR(j_oem_d, j_percent(oem_d.model.simulate_scaled(u), y, skip), 1e-9);
  }
  EXPECT_LT(j_oem_s[0], j_oem_s[1]);
  EXPECT_LT(j_oem_s[1], j_oem_s[2]);
  EXPECT_GT(j_oem_s[2], 5.0 * j_oem_s[0]);
  EXPECT_GT(j_oem_s[2], 1.0);  // a badly damped system defeats the static gradient
}

// ----- the 3-tanh static example of ch. 5 -------------------------------------------------------

struct ThreeTanh {
  // y = 2·tanh(5u − 5) + 2·tanh(−10u − 3) + tanh(3u + 2) + 1.15, u uniform in ±1.5, 1000 samples
  Eigen::VectorXd u = dsp::uniform_noise(1000, 1.5, 5);
  Eigen::VectorXd y = truth(u);

  static Eigen::VectorXd truth(const Eigen::VectorXd& x) {
    const Eigen::ArrayXd a = x.array();
    return (2.0 * (5.0 * a - 5.0).tanh() + 2.0 * (-10.0 * a - 3.0).tanh() + (3.0 * a + 2.0).tanh() + 1.15).matrix();
  }

  /// Steepest descent as in the thesis: α = 0.1, L = 1.
  static TrainingOptions thesis_sd(int iterations) {
    TrainingOptions o = options_for({TrainingMode::pem}, Optimizer::sd, iterations);
    o.step = 0.1;
    o.batch = 1;
    return o;
  }
};

/// The nodes (w, p, a) of an NN 1-3-1 up to its symmetries: each sign-flipped to w > 0 (tanh is odd),
/// then sorted by w (nodes are interchangeable).
std::vector<std::array<double, 3>> canonical_nodes(const Eigen::VectorXd& theta) {
  // θ = [w1 w2 w3 | p1 p2 p3 | a1 a2 a3 | o]
  std::vector<std::array<double, 3>> nodes;
  for (int i = 0; i < 3; ++i) {
    const double s = theta[i] < 0.0 ? -1.0 : 1.0;
    nodes.push_back({s * theta[i], s * theta[3 + i], s * theta[6 + i]});
  }
  std::sort(nodes.begin(), nodes.end());
  return nodes;
}

TEST(NarxTrainingStatic3Tanh, SmallInitialWeightsConvergeToTheTrueNetwork) {
  // Experiment 1 of the thesis: small [5F] initial weights, steepest descent α = 0.1, L = 1. Seed 3 is one
  // that shows the thesis's observation; it is not a guarantee for every seed (a few end on a saddle).
  ThreeTanh c;
  const NarxModel start = initial_model(0, 0, 0, {3}, 3, 1.5);
  const TrainingResult sd = train_narx(start, c.u, c.y, {}, {}, ThreeTanh::thesis_sd(200));
  EXPECT_LT(sd.history.back().j_est_pct, 0.01);
  // Levenberg–Marquardt from there lands on the true network up to its symmetries
  const TrainingResult lm = train_narx(sd.model, c.u, c.y, {}, {}, options_for({TrainingMode::pem}, Optimizer::lm, 50));
  EXPECT_LT(lm.history.back().j_est_pct, 1e-12);
  const std::vector<std::array<double, 3>> expected{{3.0, 2.0, 1.0}, {5.0, -5.0, 2.0}, {10.0, 3.0, -2.0}};
  const std::vector<std::array<double, 3>> found = canonical_nodes(lm.model.net.parameters());
  for (std::size_t i = 0; i < 3; ++i) {
    for (std::size_t j = 0; j < 3; ++j) EXPECT_NEAR(found[i][j], expected[i][j], 1e-6) << "node " << i << " entry " << j;
  }
  EXPECT_NEAR(lm.model.net.parameters()[9], 1.15, 1e-6);
  // and the function on a grid
  const Eigen::VectorXd grid = Eigen::VectorXd::LinSpaced(301, -1.5, 1.5);
  EXPECT_LT((lm.model.predict_scaled(grid, Eigen::VectorXd::Zero(grid.size())) - ThreeTanh::truth(grid))
                .cwiseAbs()
                .maxCoeff(),
            1e-3);
}

TEST(NarxTrainingStatic3Tanh, LargeInitialWeightsEndAtABiasedPoint) {
  // Experiment 2 of the thesis: initial weights ≈ 20× the [5F] bound, the same steepest descent and the
  // same number of iterations end on a plateau far from the optimum. The seeds are ones that show the
  // thesis's observation, not a guarantee for every seed (a lucky large start can still get close).
  ThreeTanh c;
  const double small_j =
      train_narx(initial_model(0, 0, 0, {3}, 3, 1.5), c.u, c.y, {}, {}, ThreeTanh::thesis_sd(200)).history.back().j_est_pct;
  for (const std::uint64_t seed : {3u, 4u, 7u}) {
    const NarxModel start = initial_model(0, 0, 0, {3}, seed, 1.5, 20.0);
    const TrainingResult r = train_narx(start, c.u, c.y, {}, {}, ThreeTanh::thesis_sd(200));
    EXPECT_GT(r.history.back().j_est_pct, 1.0) << "seed " << seed;
    EXPECT_GT(r.history.back().j_est_pct, 100.0 * small_j) << "seed " << seed;
  }
}

// ----- early stopping, history, steps ------------------------------------------------------------

/// A noisy, short estimation set for a too-large net (it overfits), and clean validation data.
struct OverfitCase {
  Eigen::VectorXd u = dsp::uniform_noise(300, 1.0, 1);
  Eigen::VectorXd y = 0.3 * second_order(u, 0.8) + dsp::uniform_noise(300, 0.1, 3);
  Eigen::VectorXd u_val = dsp::uniform_noise(1000, 1.0, 2);
  Eigen::VectorXd y_val = 0.3 * second_order(u_val, 0.8);
  NarxModel start = initial_model(2, 2, 0, {15}, 4);
};

TEST(NarxTrainingEarlyStopping, KeepsTheParametersWithTheBestValidationJ) {
  OverfitCase c;
  TrainingOptions o = options_for({TrainingMode::pem}, Optimizer::lm, 200);
  o.early_stopping = true;
  o.patience = 10;
  o.pem_min_progress = 0.0;  // patience alone (the progress rule: below)
  const TrainingResult r = train_narx(c.start, c.u, c.y, c.u_val, c.y_val, o);
  ASSERT_GE(r.history.size(), 2u);
  auto best = std::min_element(r.history.begin(), r.history.end(),
                               [](const TrainingRecord& a, const TrainingRecord& b) { return a.j_val_pct < b.j_val_pct; });
  // fig. 6.4: the iterations after the best one are worse on validation, and training stopped `patience` later
  ASSERT_NE(best, r.history.end() - 1);
  for (auto it = best + 1; it != r.history.end(); ++it) EXPECT_GE(it->j_val_pct, best->j_val_pct);
  EXPECT_EQ(r.history.back().iteration, best->iteration + o.patience);
  EXPECT_LT(r.iterations, o.max_iterations);
  // the returned model is the best one: its validation J, computed independently, is the minimum
  const Eigen::Index skip = 2 * (2 + 2);
  EXPECT_NEAR(j_percent(r.model.simulate_scaled(c.u_val), c.y_val, skip), best->j_val_pct, 1e-9);
}

TEST(NarxTrainingEarlyStopping, WithoutValidationDataTheLastParametersAreKept) {
  OverfitCase c;
  const TrainingOptions o = options_for({TrainingMode::pem}, Optimizer::lm, 8);
  TrainingOptions es = o;
  es.early_stopping = true;
  const TrainingResult r = train_narx(c.start, c.u, c.y, {}, {}, es);
  EXPECT_EQ(r.iterations, 8);
  for (const TrainingRecord& h : r.history) EXPECT_TRUE(std::isnan(h.j_val_pct));
  EXPECT_NEAR(j_percent(r.model.simulate_scaled(c.u), c.y, 8), r.history.back().j_est_pct, 1e-9);
}

TEST(NarxTrainingHistory, ChainingPemAndOemDRecordsBothModes) {
  OverfitCase c;
  TrainingOptions o = options_for({TrainingMode::pem, TrainingMode::oem_d}, Optimizer::lm, 5);
  std::vector<TrainingRecord> seen;
  o.progress = [&](const TrainingRecord& r) { seen.push_back(r); };
  const TrainingResult r = train_narx(c.start, c.u, c.y, c.u_val, c.y_val, o);
  ASSERT_EQ(r.history.size(), 11u);
  EXPECT_EQ(r.iterations, 10);
  EXPECT_GT(r.seconds, 0.0);
  ASSERT_EQ(seen.size(), r.history.size());
  for (std::size_t i = 0; i < r.history.size(); ++i) {
    EXPECT_EQ(r.history[i].iteration, static_cast<int>(i));
    EXPECT_EQ(seen[i].iteration, r.history[i].iteration);
    EXPECT_EQ(r.history[i].mode, i <= 5 ? TrainingMode::pem : TrainingMode::oem_d) << i;
    EXPECT_TRUE(std::isfinite(r.history[i].j_val_pct));
  }
  // record 0 is the start
  EXPECT_NEAR(r.history[0].j_est_pct, j_percent(c.start.simulate_scaled(c.u), c.y, 8), 1e-9);
  // OEM_d lowers the simulation J on the estimation data (LM accepts only decreases of its loss)
  for (std::size_t i = 6; i < r.history.size(); ++i) EXPECT_LT(r.history[i].j_est_pct, r.history[i - 1].j_est_pct);
}

TEST(NarxTrainingHistory, ThePemModeStopsAtItsOwnLimitAndTheNextModeRunsToTheCommonOne) {
  OverfitCase c;
  TrainingOptions o = options_for({TrainingMode::pem, TrainingMode::oem_d}, Optimizer::lm, 5);
  o.pem_max_iterations = 2;
  const TrainingResult r = train_narx(c.start, c.u, c.y, c.u_val, c.y_val, o);
  ASSERT_EQ(r.history.size(), 8u);  // the start, 2 pem, 5 oem-d
  for (std::size_t i = 1; i < r.history.size(); ++i) EXPECT_EQ(r.history[i].mode, i <= 2 ? TrainingMode::pem : TrainingMode::oem_d) << i;
  o.pem_max_iterations = -2;
  EXPECT_THROW((void)train_narx(c.start, c.u, c.y, c.u_val, c.y_val, o), std::invalid_argument);
}

TEST(NarxTrainingHistory, ThePemModeStopsWhenItsBestJValFellByLessThanTheMinimumProgressOverTenAndHandsOnTheRest) {
  OverfitCase c;
  TrainingOptions o = options_for({TrainingMode::pem}, Optimizer::lm, 200);
  o.early_stopping = true;
  o.patience = 200;  // the progress rule alone
  o.pem_min_progress = 0.1;
  const TrainingResult r = train_narx(c.start, c.u, c.y, c.u_val, c.y_val, o);
  // the mode's best J_val after each iteration, from the history; the first iteration i > 10 whose best is above
  // 0.9 × the best 10 iterations before is where it must have stopped
  std::vector<double> best;
  for (std::size_t i = 1; i < r.history.size(); ++i) {
    best.push_back(std::min(best.empty() ? r.history[i].j_val_pct : best.back(), r.history[i].j_val_pct));
  }
  const auto window = static_cast<std::size_t>(kPemProgressWindow);
  std::size_t expected_stop = 0;
  for (std::size_t i = window; i < best.size() && expected_stop == 0; ++i) {
    if (best[i] > 0.9 * best[i - window]) expected_stop = i + 1;
  }
  ASSERT_GT(expected_stop, window) << "the rule never applied";
  EXPECT_EQ(static_cast<std::size_t>(r.iterations), expected_stop);
  EXPECT_LT(r.iterations, o.max_iterations);
  // the next mode gets the iterations pem left: with a limit 5 above where pem stopped, oem-d runs 5 more than it
  const int stop = r.iterations;
  TrainingOptions both = o;
  both.modes = {TrainingMode::pem, TrainingMode::oem_d};
  both.max_iterations = stop + 5;
  const TrainingResult r2 = train_narx(c.start, c.u, c.y, c.u_val, c.y_val, both);
  const auto in_mode = [&](TrainingMode m) {
    return std::count_if(r2.history.begin() + 1, r2.history.end(), [&](const TrainingRecord& x) { return x.mode == m; });
  };
  EXPECT_EQ(in_mode(TrainingMode::pem), stop);
  EXPECT_EQ(in_mode(TrainingMode::oem_d), stop + 10);
  // without the rule the mode runs on
  o.pem_min_progress = 0.0;
  EXPECT_GT(train_narx(c.start, c.u, c.y, c.u_val, c.y_val, o).iterations, r.iterations);
  for (const double bad : {-0.1, 1.0, std::numeric_limits<double>::quiet_NaN()}) {
    o.pem_min_progress = bad;
    EXPECT_THROW((void)train_narx(c.start, c.u, c.y, c.u_val, c.y_val, o), std::invalid_argument) << bad;
  }
}

TEST(NarxTrainingSteepestDescent, FullBatchStepIsAlphaTimesTheGradient) {
  // [5C] with L = N: one iteration is θ − α·dV/dθ exactly, in prediction and in simulation
  DampedCase c;
  for (const TrainingMode mode : {TrainingMode::pem, TrainingMode::oem_s, TrainingMode::oem_d}) {
    TrainingOptions o = options_for({mode}, Optimizer::sd, 1);
    o.step = 0.05;
    o.batch = 0;
    o.transient_skip = 6;
    const TrainingResult r = train_narx(c.model, c.u, c.y, {}, {}, o);
    const Eigen::VectorXd expected =
        c.model.net.parameters() - 0.05 * loss_gradient(c.model, c.u, c.y, mode, 6);
    EXPECT_LT((r.model.net.parameters() - expected).cwiseAbs().maxCoeff(), 1e-13) << to_string(mode);
  }
}

TEST(NarxTrainingOptimizers, EveryOptimizerLowersTheLossOfEveryMode) {
  const Eigen::VectorXd u = dsp::uniform_noise(300, 1.0, 104);
  const Eigen::VectorXd y = second_order(u, 0.8);
  const NarxModel start = initial_model(2, 0, 0, {2}, 12);
  for (const Optimizer optimizer : {Optimizer::sd, Optimizer::linesearch, Optimizer::lm}) {
    for (const TrainingMode mode : {TrainingMode::pem, TrainingMode::oem_d, TrainingMode::oem_n}) {
      TrainingOptions o = options_for({mode}, optimizer, 10);
      o.batch = optimizer == Optimizer::sd ? 50 : 0;
      // oem_n's steepest descent takes one full-batch step per iteration (no per-batch numerical gradient)
      o.step = optimizer == Optimizer::sd && mode == TrainingMode::oem_n ? 0.5 : 0.05;
      const TrainingResult r = train_narx(start, u, y, {}, {}, o);
      // the start is on a flat part of the error surface: first-order methods move slowly there
      const double factor = optimizer == Optimizer::lm ? 0.5 : 0.95;
      EXPECT_LT(training_loss(r.model, u, y, mode, 4), factor * training_loss(start, u, y, mode, 4))
          << to_string(optimizer) << " " << to_string(mode);
    }
  }
}

// ----- sample weights ------------------------------------------------------------------------------

/// Weights in [0, 2], a quarter of them exactly 0 (seeded).
Eigen::VectorXd some_weights(Eigen::Index n, std::uint64_t seed) {
  Eigen::VectorXd w = (dsp::uniform_noise(n, 1.0, seed).array() + 1.0).matrix();
  for (Eigen::Index k = 0; k < n; k += 4) w[k] = 0.0;
  return w;
}

TEST(NarxTrainingWeights, WeightedLossIsTheWeightedMeanOfTheModelsOwnErrors) {
  DampedCase c;
  const Eigen::Index skip = 10, M = c.u.size() - skip;
  const Eigen::VectorXd w = some_weights(c.u.size(), 201);
  const Eigen::VectorXd sim = c.model.simulate_scaled(c.u), pred = c.model.predict_scaled(c.u, c.y);
  // V = Σ_{k≥skip} w(k)·e(k)² / (2·Σ_{k≥skip} w(k))
  const double v_oem = 0.5 * w.tail(M).dot((sim - c.y).tail(M).cwiseAbs2()) / w.tail(M).sum();
  const double v_pem = 0.5 * w.tail(M).dot((pred - c.y).tail(M).cwiseAbs2()) / w.tail(M).sum();
  EXPECT_NEAR(training_loss(c.model, c.u, c.y, TrainingMode::oem_d, skip, w), v_oem, 1e-14);
  EXPECT_NEAR(training_loss(c.model, c.u, c.y, TrainingMode::pem, skip, w), v_pem, 1e-14);
  EXPECT_GT(std::abs(v_oem - training_loss(c.model, c.u, c.y, TrainingMode::oem_d, skip)), 1e-6 * v_oem);
}

TEST(NarxTrainingWeights, WeightedGradientsMatchCentralDifferencesOfTheWeightedLoss) {
  DampedCase c;
  const Eigen::VectorXd w = some_weights(c.u.size(), 202);
  for (const TrainingMode mode : {TrainingMode::pem, TrainingMode::oem_d}) {
    const Eigen::VectorXd exact = loss_gradient(c.model, c.u, c.y, mode, 8, 1e-6, w);
    const Eigen::VectorXd fd = central_differences(c.model, c.u, c.y, mode, 8, 1e-5, w);
    EXPECT_LT(worst_relative_error(exact, fd), 1e-6) << to_string(mode);
  }
  // the numerical mode differences the same weighted loss
  const Eigen::VectorXd numeric = loss_gradient(c.model, c.u, c.y, TrainingMode::oem_n, 8, 1e-5, w);
  EXPECT_LT(worst_relative_error(numeric, loss_gradient(c.model, c.u, c.y, TrainingMode::oem_d, 8, 1e-6, w)), 1e-6);
}

TEST(NarxTrainingWeights, GaussNewtonMatrixIsTheWeightedMeanOfSensitivityProducts) {
  // H_w = Σ w·ψψᵀ / Σ w; with w = 0/1 on two halves it is the unweighted H of the first half (the
  // simulation of the first half does not depend on later inputs), for the numerical Jacobian as well.
  DampedCase c;
  const Eigen::Index half = 250;
  Eigen::VectorXd w = Eigen::VectorXd::Zero(c.u.size());
  w.head(half).setOnes();
  for (const TrainingMode mode : {TrainingMode::oem_d, TrainingMode::oem_n}) {
    const Eigen::MatrixXd weighted = gauss_newton_hessian(c.model, c.u, c.y, mode, 4, w);
    const Eigen::MatrixXd head = gauss_newton_hessian(c.model, c.u.head(half), c.y.head(half), mode, 4);
    EXPECT_LT((weighted - head).cwiseAbs().maxCoeff(), 1e-12 * head.cwiseAbs().maxCoeff()) << to_string(mode);
  }
}

TEST(NarxTrainingWeights, ZeroWeightsOnTheTailTrainLikeTheHeadAloneAndScaleDoesNotMatter) {
  DampedCase c;
  const Eigen::Index half = 300;
  Eigen::VectorXd w = Eigen::VectorXd::Zero(c.u.size());
  w.head(half).setConstant(3.0);  // any constant: V divides by Σ w
  for (const Optimizer optimizer : {Optimizer::lm, Optimizer::sd}) {
    TrainingOptions o = options_for({TrainingMode::oem_d}, optimizer, 4);
    o.transient_skip = 6;
    o.step = 0.05;
    const TrainingResult head = train_narx(c.model, c.u.head(half), c.y.head(half), {}, {}, o);
    o.weights = w;
    const TrainingResult weighted = train_narx(c.model, c.u, c.y, {}, {}, o);
    EXPECT_GT((head.model.net.parameters() - c.model.net.parameters()).norm(), 1e-6) << to_string(optimizer);
    EXPECT_LT((weighted.model.net.parameters() - head.model.net.parameters()).cwiseAbs().maxCoeff(), 1e-10)
        << to_string(optimizer);
  }
}

TEST(NarxTrainingWeights, EarlyStoppingWatchesTheWeightedValidationJ) {
  DampedCase c;
  const Eigen::VectorXd uv = dsp::uniform_noise(300, 1.0, 203), yv = second_order(uv, 0.9);
  const Eigen::VectorXd wv = some_weights(uv.size(), 204);
  TrainingOptions o = options_for({TrainingMode::oem_d}, Optimizer::lm, 3);
  o.transient_skip = 6;
  o.early_stopping = true;
  o.validation_weights = wv;
  const TrainingResult r = train_narx(c.model, c.u, c.y, uv, yv, o);
  // record 0 is the start: its figures from the model's own simulation of the validation record
  const Eigen::Index M = uv.size() - 6;
  const Eigen::VectorXd e = (c.model.simulate_scaled(uv) - yv).tail(M);
  const double j = 100.0 * e.squaredNorm() / yv.tail(M).squaredNorm();
  const double j_weighted = 100.0 * wv.tail(M).dot(e.cwiseAbs2()) / wv.tail(M).dot(yv.tail(M).cwiseAbs2());
  ASSERT_FALSE(r.history.empty());
  EXPECT_NEAR(r.history.front().j_val_pct, j, 1e-9 * j);
  EXPECT_NEAR(r.history.front().j_val_weighted_pct, j_weighted, 1e-9 * j_weighted);
  EXPECT_GT(std::abs(j_weighted - j), 1e-6 * j);
  // without weights the two figures are one
  o.validation_weights.resize(0);
  const TrainingResult plain = train_narx(c.model, c.u, c.y, uv, yv, o);
  EXPECT_EQ(plain.history.front().j_val_weighted_pct, plain.history.front().j_val_pct);
}

TEST(NarxTrainingWeights, BadWeightsAreRejectedWithAReason) {
  DampedCase c;
  TrainingOptions o = options_for({TrainingMode::pem}, Optimizer::lm, 2);
  auto message = [&](const TrainingOptions& options, const Eigen::VectorXd& uv, const Eigen::VectorXd& yv) {
    try {
      train_narx(c.model, c.u, c.y, uv, yv, options);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const Eigen::VectorXd none;
  o.weights = Eigen::VectorXd::Ones(c.u.size() - 1);
  EXPECT_NE(message(o, none, none).find("estimation weights have 499 entries"), std::string::npos);
  o.weights = Eigen::VectorXd::Ones(c.u.size());
  o.weights[77] = -1.0;
  EXPECT_NE(message(o, none, none).find("weight at sample 77"), std::string::npos);
  o.weights[77] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(message(o, none, none).find("weight at sample 77"), std::string::npos);
  o.weights.setZero();
  o.weights.head(4).setOnes();  // only inside the transient skip of 2·(na + nb) = 4
  EXPECT_NE(message(o, none, none).find("all 0 after the transient skip"), std::string::npos);
  o.weights.resize(0);
  o.validation_weights = Eigen::VectorXd::Ones(10);
  EXPECT_NE(message(o, none, none).find("without validation data"), std::string::npos);
  EXPECT_NE(message(o, c.u.head(100), c.y.head(100)).find("validation weights have 10 entries"), std::string::npos);
}

// ----- names and errors ----------------------------------------------------------------------------

TEST(NarxTrainingNames, ParseAndPrintRoundTrip) {
  for (const TrainingMode m : {TrainingMode::pem, TrainingMode::oem_s, TrainingMode::oem_d, TrainingMode::oem_n}) {
    EXPECT_EQ(parse_training_mode(to_string(m)), m);
  }
  for (const Optimizer o : {Optimizer::sd, Optimizer::linesearch, Optimizer::lm}) EXPECT_EQ(parse_optimizer(to_string(o)), o);
  EXPECT_EQ(to_string(TrainingMode::oem_d), "oem-d");
  EXPECT_THROW(parse_training_mode("oem_d"), std::invalid_argument);
  EXPECT_THROW(parse_optimizer("adam"), std::invalid_argument);
}

TEST(NarxTrainingErrors, BadInputIsRejectedWithAReason) {
  DampedCase c;
  const TrainingOptions o = options_for({TrainingMode::pem}, Optimizer::lm, 2);
  const Eigen::VectorXd none;
  auto expect_error = [&](auto&& call, const std::string& fragment) {
    try {
      call();
      ADD_FAILURE() << "expected std::invalid_argument mentioning \"" << fragment << "\"";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  // lengths
  expect_error([&] { train_narx(c.model, c.u.head(400), c.y, none, none, o); }, "samples");
  expect_error([&] { train_narx(c.model, c.u, c.y, c.u.head(100), c.y.head(99), o); }, "validation");
  expect_error([&] { loss_gradient(c.model, c.u, c.y.head(10), TrainingMode::oem_d, 0); }, "samples");
  // non-finite data
  Eigen::VectorXd bad = c.y;
  bad[123] = std::numeric_limits<double>::quiet_NaN();
  expect_error([&] { train_narx(c.model, c.u, bad, none, none, o); }, "sample 123");
  expect_error([&] { training_loss(c.model, c.u, bad, TrainingMode::pem, 0); }, "not finite");
  // too short for the structure: NN 3-3-1 has P = 16, skip 4 → N must exceed 20
  expect_error([&] { train_narx(c.model, c.u.head(20), c.y.head(20), none, none, o); }, "N > 20");
  EXPECT_NO_THROW(train_narx(c.model, c.u.head(21), c.y.head(21), none, none, o));
  expect_error([&] { training_loss(c.model, c.u.head(5), c.y.head(5), TrainingMode::pem, 5); }, "transient skip");
  // options
  TrainingOptions bad_options = o;
  bad_options.modes.clear();
  expect_error([&] { train_narx(c.model, c.u, c.y, none, none, bad_options); }, "mode");
  bad_options = o;
  bad_options.optimizer = Optimizer::sd;
  bad_options.step = 0.0;
  expect_error([&] { train_narx(c.model, c.u, c.y, none, none, bad_options); }, "step");
  bad_options = o;
  bad_options.batch = -1;
  expect_error([&] { train_narx(c.model, c.u, c.y, none, none, bad_options); }, "batch");
  bad_options = o;
  bad_options.transient_skip = -2;
  expect_error([&] { train_narx(c.model, c.u, c.y, none, none, bad_options); }, "transient_skip");
  // a network that does not fit the structure, and non-finite weights
  NarxModel mismatched = c.model;
  mismatched.structure.na = 3;
  expect_error([&] { train_narx(mismatched, c.u, c.y, none, none, o); }, "inputs");
  NarxModel broken = c.model;
  broken.net.parameters()[2] = std::numeric_limits<double>::infinity();
  expect_error([&] { train_narx(broken, c.u, c.y, none, none, o); }, "θ");
}

// ----- selection on the J reported (issue #36) ------------------------------------------------------

TEST(NarxTrainingSelection, KeepsTheRefinementWhenTheValidationRecordStartsMidStream) {
  // The reproduction: poles 0.99·e^{±j23°}, uniform white input, output scaled to peak 1 plus
  // Gaussian noise of σ = 0.05 % of the peak; 3000 estimation samples, the next 2000 validation (a split of
  // one record, so the validation record starts mid-stream); NN na = 2, nb = 0, 5 hidden, pem then oem-d
  // by LM. Judged as validate --init 50 judges it: the first 50 measured outputs set the state. 500
  // iterations per mode, not the 200: on this realisation LM crawls along the oem-d valley and
  // stands at 5.7× the floor after 200 (bench/selection_repro.sh runs the 200 on its own data).
  const Eigen::VectorXd u = dsp::uniform_noise(5000, 1.0, 36);
  const Eigen::VectorXd clean = second_order(u, 0.99);
  const Eigen::VectorXd noise = 5e-4 * dsp::gaussian_noise(5000, 3.0, 37);  // σ = 1 (redrawn past 3σ) × 5e-4
  const Eigen::VectorXd y = clean + noise;
  const Eigen::VectorXd ue = u.head(3000), ye = y.head(3000), uv = u.tail(2000), yv = y.tail(2000);
  constexpr Eigen::Index init = 50;
  // the noise floor: the J of the noise-free output on the validation record
  const double floor_pct = j_percent(clean.tail(2000), yv, init);
  TrainingOptions o = options_for({TrainingMode::pem, TrainingMode::oem_d}, Optimizer::lm, 500);
  o.early_stopping = true;
  o.init = init;
  const TrainingResult r = train_narx(initial_model(2, 0, 0, {5}, 1), ue, ye, uv, yv, o);
  const double j_val = j_percent(r.model.simulate_scaled(uv, yv, init), yv, init);
  EXPECT_LT(j_val, 2.0 * floor_pct) << "noise floor " << floor_pct << " %";
  // the J the history reports is the J of validate --init, and the kept model is the history's best
  double best = std::numeric_limits<double>::infinity();
  for (const TrainingRecord& rec : r.history) best = std::min(best, rec.j_val_pct);
  EXPECT_NEAR(j_val, best, 1e-9 * best);
}

TEST(NarxTrainingWeightDecay, LmStopsWhereTheRegularisedCriterionIsStationary) {
  // NNSYSID's W = (Σ e² + D·θᵀθ)/(2M), M = N − skip: at its minimum dV/dθ + (D/M)·θ = 0, dV/dθ from
  // loss_gradient (independent of the trainer), and θ is shorter than without the decay.
  DampedCase c;
  constexpr double D = 1.0;
  constexpr Eigen::Index skip = 4;
  TrainingOptions o = options_for({TrainingMode::pem}, Optimizer::lm, 300);
  o.transient_skip = skip;
  const NarxModel free = train_narx(c.model, c.u, c.y, {}, {}, o).model;
  o.weight_decay = D;
  const NarxModel decayed = train_narx(c.model, c.u, c.y, {}, {}, o).model;
  const Eigen::VectorXd& theta = decayed.net.parameters();
  const double per_sample = D / static_cast<double>(c.u.size() - skip);
  const Eigen::VectorXd stationarity = loss_gradient(decayed, c.u, c.y, TrainingMode::pem, skip) + per_sample * theta;
  EXPECT_LT(stationarity.norm(), 1e-4 * (per_sample * theta).norm());
  EXPECT_LT(theta.norm(), free.net.parameters().norm());
}

TEST(NarxTrainingWeightDecay, TheEvidenceRuleSetsTheNextDecayFromTheGaussNewtonMatrix) {
  // The D after the first PEM iteration is MacKay's update at the start θ, computed here from the public
  // Gauss–Newton matrix and loss (M·H = JᵀJ, 2·M·V = Σe², M = N − skip); with the rule for the output-error
  // modes alone, PEM keeps the D it was given.
  DampedCase c;
  constexpr double D = 0.05;
  constexpr Eigen::Index skip = 4;
  TrainingOptions o = options_for({TrainingMode::pem}, Optimizer::lm, 3);
  o.transient_skip = skip;
  o.weight_decay = D;
  o.evidence_decay = EvidenceDecay::all_modes;
  const TrainingResult r = train_narx(c.model, c.u, c.y, {}, {}, o);
  ASSERT_GE(r.history.size(), 2u);
  const double M = static_cast<double>(c.u.size() - skip);
  const Eigen::MatrixXd H = gauss_newton_hessian(c.model, c.u, c.y, TrainingMode::pem, skip);
  const double V = training_loss(c.model, c.u, c.y, TrainingMode::pem, skip);
  const Eigen::Index P = c.model.net.parameter_count();
  const double expected = evidence_weight_decay(M * H + D * Eigen::MatrixXd::Identity(P, P), 2.0 * M * V, M, D,
                                                c.model.net.parameters());
  EXPECT_NEAR(r.history[1].weight_decay, expected, 1e-9 * expected);
  EXPECT_NE(expected, D);
  o.evidence_decay = EvidenceDecay::output_error;
  for (const TrainingRecord& rec : train_narx(c.model, c.u, c.y, {}, {}, o).history) EXPECT_EQ(rec.weight_decay, D);
}

TEST(NarxTrainingSelection, RefusesABadInitAndABadWeightDecay) {
  DampedCase c;
  const auto expect_error = [](auto&& call, const std::string& fragment) {
    try {
      call();
      ADD_FAILURE() << "no exception; expected one naming " << fragment;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  expect_error([&] { training_loss(c.model, c.u, c.y, TrainingMode::oem_d, 10, {}, 11); }, "init");
  TrainingOptions o = options_for({TrainingMode::pem}, Optimizer::lm, 1);
  o.init = -1;
  expect_error([&] { train_narx(c.model, c.u, c.y, {}, {}, o); }, "init");
  o.init = 0;
  o.weight_decay = -1.0;
  expect_error([&] { train_narx(c.model, c.u, c.y, {}, {}, o); }, "weight_decay");
  o.weight_decay = 1.0;
  o.optimizer = Optimizer::sd;
  expect_error([&] { train_narx(c.model, c.u, c.y, {}, {}, o); }, "weight_decay");
}

}  // namespace
}  // namespace panelbass::models

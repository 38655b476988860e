// The MLP of thesis fig. 5.6 against independent expectations: the thesis's static example evaluated
// from its formula, a plain loop evaluation of θ's documented layout, central finite differences for
// every gradient, and the [5F] bound on the initial node inputs checked analytically.
#include "models/narx/mlp.h"
#include "models/narx/mlp_kernel.h"
#include "models/narx/narx_history.h"
#include "models/narx/narx_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <utility>
#include <stdexcept>
#include <vector>

#include "dsp/random.h"

namespace panelbass::models {
namespace {

// F(x) written out with plain loops over θ's documented layout: per layer the weight matrix row by
// row (row = one node's inputs), then the biases; tanh hidden nodes, a linear output node last.
double plain_forward(const Eigen::VectorXd& theta, int inputs, const std::vector<int>& hidden,
                     const Eigen::VectorXd& x) {
  std::vector<double> in(x.data(), x.data() + x.size());
  Eigen::Index p = 0;
  int n_in = inputs;
  for (int n_out : hidden) {
    std::vector<double> out(static_cast<std::size_t>(n_out));
    for (int i = 0; i < n_out; ++i) {
      double s = theta[p + static_cast<Eigen::Index>(n_out) * n_in + i];  // bias of node i
      for (int j = 0; j < n_in; ++j) s += theta[p + static_cast<Eigen::Index>(i) * n_in + j] * in[j];
      out[static_cast<std::size_t>(i)] = std::tanh(s);
    }
    p += static_cast<Eigen::Index>(n_out) * (n_in + 1);
    in = out;
    n_in = n_out;
  }
  double y = theta[p + n_in];
  for (int j = 0; j < n_in; ++j) y += theta[p + j] * in[static_cast<std::size_t>(j)];
  return y;
}

// Σ|w|·bound + |b| for every node of the layer starting at θ[p]: the largest |node_in| over inputs in
// [−bound, bound] (attained at the box corner x = bound·sign(w)).
std::vector<double> worst_node_inputs(const Eigen::VectorXd& theta, Eigen::Index p, int n_in, int n_out,
                                      double bound) {
  std::vector<double> worst;
  for (int i = 0; i < n_out; ++i) {
    double s = std::abs(theta[p + static_cast<Eigen::Index>(n_out) * n_in + i]);
    for (int j = 0; j < n_in; ++j) s += std::abs(theta[p + static_cast<Eigen::Index>(i) * n_in + j]) * bound;
    worst.push_back(s);
  }
  return worst;
}

// Fourth-order central difference (h = 1e-3: truncation ~h⁴, rounding ~1e-16/h, both ≪ 1e-7).
template <class F>
double central_difference(F f, double h = 1e-3) {
  return (-f(2.0 * h) + 8.0 * f(h) - 8.0 * f(-h) + f(-2.0 * h)) / (12.0 * h);
}

// ∂F/∂θ and ∂F/∂x from backward() against finite differences of forward(), relative to the gradient's scale.
void expect_gradients_match_finite_differences(int inputs, const std::vector<int>& hidden, std::uint64_t seed) {
  Mlp net(inputs, hidden);
  net.initialize(1.0, seed, 3.0);  // weights large enough that every layer is visibly nonlinear
  Mlp::Workspace ws = net.workspace();
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(inputs, -0.9, 0.7);
  net.forward(x, ws);
  Eigen::VectorXd dtheta(net.parameter_count());
  Eigen::VectorXd dx(inputs);
  net.backward(ws, dtheta, dx);

  const double dtheta_scale = dtheta.cwiseAbs().maxCoeff();
  for (Eigen::Index i = 0; i < net.parameter_count(); ++i) {
    const double fd = central_difference([&](double h) {
      Mlp perturbed = net;
      perturbed.parameters()[i] += h;
      Mlp::Workspace w = perturbed.workspace();
      return perturbed.forward(x, w);
    });
    EXPECT_NEAR(dtheta[i], fd, 1e-7 * std::max(std::abs(fd), dtheta_scale)) << "theta[" << i << "]";
  }
  const double dx_scale = dx.cwiseAbs().maxCoeff();
  for (Eigen::Index j = 0; j < inputs; ++j) {
    const double fd = central_difference([&](double h) {
      Eigen::VectorXd xp = x;
      xp[j] += h;
      Mlp::Workspace w = net.workspace();
      return net.forward(xp, w);
    });
    EXPECT_NEAR(dx[j], fd, 1e-7 * std::max(std::abs(fd), dx_scale)) << "x[" << j << "]";
  }
}

TEST(Mlp, ForwardReproducesThesisStaticExample) {
  // Thesis ch. 5: y = 2tanh(5u − 5) + 2tanh(−10u − 3) + tanh(3u + 2) + 1.15 is NN 1-3-1 with
  // W_true = [5 −10 3], P_true = [−5 −3 2], A_true = [2 2 1], O_true = 1.15.
  Mlp net(1, {3});
  ASSERT_EQ(net.parameter_count(), 10);
  net.parameters() << 5.0, -10.0, 3.0, -5.0, -3.0, 2.0, 2.0, 2.0, 1.0, 1.15;
  Mlp::Workspace ws = net.workspace();
  for (double u = -1.5; u <= 1.5; u += 0.125) {
    const double expected = 2.0 * std::tanh(5.0 * u - 5.0) + 2.0 * std::tanh(-10.0 * u - 3.0) + std::tanh(3.0 * u + 2.0) + 1.15;
    Eigen::VectorXd x(1);
    x << u;
    EXPECT_NEAR(net.forward(x, ws), expected, 1e-14) << "u = " << u;
  }
}

TEST(Mlp, ForwardFollowsDocumentedLayoutForOneAndTwoHiddenLayers) {
  for (const std::vector<int>& hidden : {std::vector<int>{4}, std::vector<int>{4, 3}, std::vector<int>{2, 5, 3}}) {
    Mlp net(3, hidden);
    net.initialize(1.0, 42, 4.0);
    Mlp::Workspace ws = net.workspace();
    for (int t = 0; t < 5; ++t) {
      const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(3, -1.0 + 0.3 * t, 0.8 - 0.2 * t);
      EXPECT_NEAR(net.forward(x, ws), plain_forward(net.parameters(), 3, hidden, x), 1e-13);
      EXPECT_EQ(ws.input, x);
    }
  }
}

// The code paths this CPU runs: the baseline always, AVX2 + FMA where the CPU has them.
std::vector<SimdLevel> available_levels() {
  std::vector<SimdLevel> levels = {SimdLevel::baseline};
  if (avx2_fma_available()) levels.push_back(SimdLevel::avx2_fma);
  return levels;
}

TEST(TanhInPlace, IsWithin1e15OfStdTanhAndKeepsTheLimitsAndNaN) {
  // A dense grid over the range a node input takes and beyond, plus the tiny and the special values.
  std::vector<double> x;
  for (int i = -40000; i <= 40000; ++i) x.push_back(i * 6.25e-4);  // [−25, 25]
  for (double tiny : {1e-300, 1e-20, 1e-9, 3e-5}) {
    x.push_back(tiny);
    x.push_back(-tiny);
  }
  const double inf = std::numeric_limits<double>::infinity();
  x.insert(x.end(), {-0.0, 400.0, -400.0, 1e300, -1e300, inf, -inf});
  // Both code paths (AVX2 + FMA only where this CPU has it); an odd count leaves a partial vector.
  for (const SimdLevel level : available_levels()) {
    std::vector<double> y = x;
    tanh_in_place(y, level);
    double worst = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) worst = std::max(worst, std::abs(y[i] - std::tanh(x[i])));
    EXPECT_LE(worst, 1e-15) << static_cast<int>(level);
    EXPECT_EQ(y[y.size() - 2], 1.0);
    EXPECT_EQ(y[y.size() - 1], -1.0);
    std::vector<double> nan = {0.5, std::numeric_limits<double>::quiet_NaN(), 0.25};
    tanh_in_place(nan, level);
    EXPECT_TRUE(std::isnan(nan[1]));
    EXPECT_NEAR(nan[0], std::tanh(0.5), 1e-15);
  }
}

TEST(MlpKernel, GivesTheDocumentedLayoutsOutputWithTheInputSplitAnywhere) {
  // Widths on and off the kernel's multiples of 4, no hidden layer, and the thesis's NN 17-17-1.
  const std::vector<std::pair<int, std::vector<int>>> shapes = {
      {3, {}}, {3, {4}}, {5, {7, 3}}, {17, {17}}, {2, {5, 8, 1}}};
  for (const auto& [inputs, hidden] : shapes) {
    Mlp net(inputs, hidden);
    net.initialize(1.0, 7, 3.0);  // weights large enough that every tanh is visibly nonlinear
    for (const SimdLevel level : available_levels()) {
      MlpKernel kernel(net, level);
      ASSERT_EQ(kernel.inputs(), inputs);
      ASSERT_EQ(kernel.level(), level);
      const MlpKernel copy = kernel;  // a copy reads its own weights
      dsp::Rng rng(11);
      for (int t = 0; t < 20; ++t) {
        Eigen::VectorXd x(inputs);
        for (double& v : x) v = rng.uniform(-1.0, 1.0);
        const double expected = plain_forward(net.parameters(), inputs, hidden, x);
        const auto split = static_cast<std::size_t>(t % (inputs + 1));
        const std::span<const double> all(x.data(), static_cast<std::size_t>(inputs));
        EXPECT_NEAR(kernel.forward(all.first(split), all.subspan(split)), expected, 1e-13)
            << inputs << " inputs, " << hidden.size() << " layers, split " << split << ", level "
            << static_cast<int>(level);
        EXPECT_EQ(MlpKernel(copy).forward(all.first(split), all.subspan(split)),
                  kernel.forward(all.first(split), all.subspan(split)));
      }
    }
  }
}

TEST(MlpKernel, FreeRunIsForwardSampleBySampleToTheBit) {
  // free_run keeps the newest output in a register: the same arithmetic as forward() on the histories,
  // so the same bits, for every code path and shape (one layer: the register path; others: forward per sample).
  const std::vector<std::pair<models::NarxStructure, int>> shapes = [] {
    models::NarxStructure thesis, delayed, layers, none;
    delayed.na = 3;
    delayed.nb = 2;
    delayed.nk = 2;
    delayed.hidden = {5};
    layers.na = 2;
    layers.nb = 3;
    layers.hidden = {7, 3};
    none.na = 2;
    none.nb = 1;
    none.hidden = {};
    return std::vector<std::pair<models::NarxStructure, int>>{{thesis, 17}, {delayed, 6}, {layers, 6}, {none, 4}};
  }();
  for (const auto& [st, inputs] : shapes) {
    Mlp net(inputs, st.hidden);
    net.initialize(1.0, 29, 2.0);
    for (const SimdLevel level : available_levels()) {
      MlpKernel kernel(net, level);
      NarxHistory by_sample(st), by_block(st);
      dsp::Rng rng(31);
      std::vector<double> u(300), expected(300), y(300);
      for (double& v : u) v = rng.uniform(-1.0, 1.0);
      for (std::size_t k = 0; k < u.size(); ++k) {
        by_sample.push_input(u[k]);
        expected[k] = kernel.forward(by_sample.past_outputs(), by_sample.past_inputs());
        by_sample.push_output(expected[k]);
      }
      kernel.free_run(by_block, std::span<const double>(u).first(37), std::span<double>(y).first(37));
      kernel.free_run(by_block, std::span<const double>(u).subspan(37), std::span<double>(y).subspan(37));
      for (std::size_t k = 0; k < u.size(); ++k) {
        ASSERT_EQ(y[k], expected[k]) << inputs << " inputs, level " << static_cast<int>(level) << ", sample " << k;
      }
      EXPECT_EQ(by_block.past_outputs()[0], by_sample.past_outputs()[0]);
    }
  }
}

TEST(Mlp, RowByRowLayoutOfASmallNet) {
  // NN 2-2-1, θ = [w00 w01 w10 w11 b0 b1 v0 v1 c]: node i sees row i.
  Mlp net(2, {2});
  net.parameters() << 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9;
  Eigen::VectorXd x(2);
  x << 1.0, -2.0;
  Mlp::Workspace ws = net.workspace();
  const double a0 = std::tanh(0.1 * 1.0 + 0.2 * -2.0 + 0.5);
  const double a1 = std::tanh(0.3 * 1.0 + 0.4 * -2.0 + 0.6);
  EXPECT_NEAR(net.forward(x, ws), 0.7 * a0 + 0.8 * a1 + 0.9, 1e-15);
  EXPECT_NEAR(ws.activation[0][0], a0, 1e-15);
  EXPECT_NEAR(ws.activation[0][1], a1, 1e-15);
}

TEST(Mlp, GradientsMatchFiniteDifferencesOneHiddenLayer) { expect_gradients_match_finite_differences(5, {6}, 7); }

TEST(Mlp, GradientsMatchFiniteDifferencesTwoHiddenLayers) {
  expect_gradients_match_finite_differences(4, {5, 3}, 8);
}

TEST(Mlp, GradientsMatchFiniteDifferencesThreeHiddenLayers) {
  expect_gradients_match_finite_differences(3, {4, 3, 2}, 9);
}

TEST(Mlp, GradientOfThesisExampleInClosedForm) {
  // F = Σ A_i tanh(W_i u + P_i) + O: ∂F/∂W_i = A_i(1 − t_i²)u, ∂F/∂P_i = A_i(1 − t_i²), ∂F/∂A_i = t_i,
  // ∂F/∂O = 1, ∂F/∂u = Σ A_i(1 − t_i²)W_i.
  Mlp net(1, {3});
  const double W[3] = {5.0, -10.0, 3.0}, P[3] = {-5.0, -3.0, 2.0}, A[3] = {2.0, 2.0, 1.0};
  net.parameters() << W[0], W[1], W[2], P[0], P[1], P[2], A[0], A[1], A[2], 1.15;
  const double u = -0.3;
  Eigen::VectorXd x(1);
  x << u;
  Mlp::Workspace ws = net.workspace();
  net.forward(x, ws);
  Eigen::VectorXd dtheta(10), dx(1);
  net.backward(ws, dtheta, dx);
  double dfdu = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double t = std::tanh(W[i] * u + P[i]);
    EXPECT_NEAR(dtheta[i], A[i] * (1.0 - t * t) * u, 1e-14);
    EXPECT_NEAR(dtheta[3 + i], A[i] * (1.0 - t * t), 1e-14);
    EXPECT_NEAR(dtheta[6 + i], t, 1e-15);
    dfdu += A[i] * (1.0 - t * t) * W[i];
  }
  EXPECT_EQ(dtheta[9], 1.0);
  EXPECT_NEAR(dx[0], dfdu, 1e-13);
}

TEST(Mlp, BackwardWithoutInputGradientGivesTheSameParameterGradient) {
  Mlp net(4, {5, 3});
  net.initialize(1.0, 5);
  Mlp::Workspace ws = net.workspace();
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(4, -0.5, 0.5);
  net.forward(x, ws);
  Eigen::VectorXd with_dx(net.parameter_count()), without_dx(net.parameter_count()), dx(4);
  net.backward(ws, with_dx, dx);
  Eigen::VectorXd empty;
  net.backward(ws, without_dx, empty);
  EXPECT_EQ(with_dx, without_dx);
}

TEST(Mlp, InitialWeightsKeepEveryNodeOutOfSaturation) {
  // [5F]: |node_in| ≤ Σ|w|·Input_max + |b| for x in [−Input_max, Input_max]; tanh outputs lie in (−1, 1)
  // so the next layers see Input_max = 1. All must stay below 2 for every x in the box.
  for (double input_max : {0.5, 1.0, 3.0}) {
    for (std::uint64_t seed : {1u, 2u, 3u}) {
      const int inputs = 17;
      const std::vector<int> hidden{17, 9};
      Mlp net(inputs, hidden);
      net.initialize(input_max, seed);
      const Eigen::VectorXd& theta = net.parameters();
      Eigen::Index p = 0;
      int n_in = inputs;
      double bound = input_max;
      for (std::size_t l = 0; l <= hidden.size(); ++l) {
        const int n_out = l < hidden.size() ? hidden[l] : 1;
        for (double worst : worst_node_inputs(theta, p, n_in, n_out, bound)) {
          EXPECT_LT(worst, 2.0) << "layer " << l << ", input_max " << input_max << ", seed " << seed;
        }
        // The range is used, not just respected: the largest |w| comes close to Max.
        const double max = 2.0 / (bound * n_in + 1.0);
        const Eigen::Index count = static_cast<Eigen::Index>(n_out) * (n_in + 1);
        EXPECT_LE(theta.segment(p, count).cwiseAbs().maxCoeff(), max) << "layer " << l;
        if (l < hidden.size()) {
          EXPECT_GT(theta.segment(p, count).cwiseAbs().maxCoeff(), 0.9 * max) << "layer " << l;
        }
        p += count;
        n_in = n_out;
        bound = 1.0;
      }
      EXPECT_EQ(p, net.parameter_count());
    }
  }
}

TEST(Mlp, LargeInitialWeightsSaturateNodes) {
  // scale = 10: the thesis's "large initial weights" run; some node can be driven past |node_in| = 2.
  const int inputs = 17;
  Mlp net(inputs, {17});
  net.initialize(1.0, 4, 10.0);
  const std::vector<double> worst = worst_node_inputs(net.parameters(), 0, inputs, 17, 1.0);
  int node = 0;
  for (int i = 1; i < 17; ++i) {
    if (worst[static_cast<std::size_t>(i)] > worst[static_cast<std::size_t>(node)]) node = i;
  }
  ASSERT_GT(worst[static_cast<std::size_t>(node)], 2.0);
  // At the corner x = sign(w_node) the node's output is saturated: |tanh(node_in)| > tanh(2).
  Eigen::VectorXd x(inputs);
  for (int j = 0; j < inputs; ++j) x[j] = net.parameters()[node * inputs + j] >= 0.0 ? 1.0 : -1.0;
  if (net.parameters()[17 * inputs + node] < 0.0) x = -x;
  Mlp::Workspace ws = net.workspace();
  net.forward(x, ws);
  EXPECT_GT(std::abs(ws.activation[0][node]), std::tanh(2.0));
}

TEST(Mlp, InitializeIsDeterministicForASeed) {
  Mlp a(5, {4, 3}), b(5, {4, 3}), c(5, {4, 3});
  a.initialize(1.0, 99);
  b.initialize(1.0, 99);
  c.initialize(1.0, 100);
  EXPECT_EQ(a.parameters(), b.parameters());
  EXPECT_NE(a.parameters(), c.parameters());
}

TEST(Mlp, ParameterCount) {
  EXPECT_EQ(Mlp(17, {17}).parameter_count(), 17 * 17 + 17 + 17 + 1);  // 324
  EXPECT_EQ(Mlp(17, {17}).parameter_count(), 324);
  EXPECT_EQ(Mlp(3, {4, 2}).parameter_count(), 3 * 4 + 4 + 4 * 2 + 2 + 2 + 1);
  const Mlp fresh(2, {3});
  EXPECT_EQ(fresh.parameters().size(), fresh.parameter_count());
  EXPECT_TRUE(fresh.parameters().isZero());
  EXPECT_EQ(fresh.inputs(), 2);
  EXPECT_EQ(fresh.hidden(), std::vector<int>{3});
}

TEST(Mlp, WorkspaceHasTheNetworkSizes) {
  const Mlp net(6, {5, 4});
  const Mlp::Workspace ws = net.workspace();
  EXPECT_EQ(ws.input.size(), 6);
  ASSERT_EQ(ws.activation.size(), 2u);
  ASSERT_EQ(ws.delta.size(), 2u);
  EXPECT_EQ(ws.activation[0].size(), 5);
  EXPECT_EQ(ws.activation[1].size(), 4);
  EXPECT_EQ(ws.delta[1].size(), 4);
}

TEST(Mlp, RejectsBadShapes) {
  EXPECT_THROW(Mlp(0, {3}), std::invalid_argument);
  EXPECT_THROW(Mlp(2, {3, 0}), std::invalid_argument);
  Mlp net(2, {3});
  Mlp::Workspace ws = net.workspace();
  EXPECT_THROW(net.forward(Eigen::VectorXd::Zero(3), ws), std::invalid_argument);
  EXPECT_THROW(net.initialize(0.0, 1), std::invalid_argument);
  EXPECT_THROW(net.initialize(1.0, 1, -1.0), std::invalid_argument);
  net.forward(Eigen::VectorXd::Zero(2), ws);
  Eigen::VectorXd wrong(net.parameter_count() - 1), dx(2);
  EXPECT_THROW(net.backward(ws, wrong, dx), std::invalid_argument);
}

TEST(Mlp, DefaultWorkspaceIsSizedOnFirstUse) {
  Mlp net(2, {3});
  net.initialize(1.0, 3);
  Mlp::Workspace ws;
  const Eigen::VectorXd x = Eigen::VectorXd::Constant(2, 0.4);
  EXPECT_NEAR(net.forward(x, ws), plain_forward(net.parameters(), 2, {3}, x), 1e-15);
}

TEST(Mlp, TheUncheckedForwardGivesTheCheckedOnesOutputToTheBit) {
  for (const std::vector<int>& hidden : {std::vector<int>{}, std::vector<int>{5}, std::vector<int>{4, 3}}) {
    Mlp net(3, hidden);
    net.initialize(1.0, 11);
    Mlp::Workspace checked = net.workspace(), unchecked = net.workspace();
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3d x(std::sin(0.7 * k), std::cos(1.3 * k), 0.1 * k - 1.0);
      ASSERT_EQ(net.forward_unchecked(x, unchecked), net.forward(x, checked)) << k;
      ASSERT_EQ(unchecked.activation.size(), checked.activation.size());
      for (std::size_t l = 0; l < checked.activation.size(); ++l) ASSERT_EQ(unchecked.activation[l], checked.activation[l]);
    }
  }
}

TEST(Mlp, FitsTellsAWorkspaceOfTheNetworksSizesFromAnother) {
  const Mlp net(3, {4, 2});
  EXPECT_TRUE(net.fits(net.workspace()));
  EXPECT_FALSE(net.fits(Mlp::Workspace{}));
  EXPECT_FALSE(net.fits(Mlp(3, {4, 3}).workspace()));
  EXPECT_FALSE(net.fits(Mlp(2, {4, 2}).workspace()));
}

}  // namespace
}  // namespace panelbass::models

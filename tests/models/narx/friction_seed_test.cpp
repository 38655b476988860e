#include "models/narx/friction_seed.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "dsp/random.h"

namespace panelbass::models {
namespace {

// A mass on a spring with damping, driven by u: the acceleration y is measured, the velocity v is the
// truth the seeded nodes should follow. Semi-implicit Euler at fs = 1, resonance 0.04·fs.
struct Resonator {
  Eigen::VectorXd u, y, v;
};

Resonator simulate_resonator(Eigen::Index n, std::uint64_t seed) {
  const double w0 = 2.0 * std::numbers::pi * 0.04, damping = 0.1;
  dsp::Rng rng(seed);
  Resonator r{Eigen::VectorXd(n), Eigen::VectorXd(n), Eigen::VectorXd(n)};
  double x = 0.0, v = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    r.u[k] = rng.uniform(-1.0, 1.0);
    const double a = r.u[k] - 2.0 * damping * w0 * v - w0 * w0 * x;
    v += a;
    x += v;
    r.y[k] = a;
    r.v[k] = v;
  }
  return r;
}

double correlation(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::VectorXd ca = a.array() - a.mean(), cb = b.array() - b.mean();
  return ca.dot(cb) / std::sqrt(ca.squaredNorm() * cb.squaredNorm());
}

NarxModel initialised_model(int hidden) {
  NarxModel m = NarxModel::with_structure({4, 4, 0, {hidden}}, Scaling{}, 1.0);
  m.net.initialize(1.0, 7);
  return m;
}

TEST(FrictionSeed, SeededNodesFollowTheTrueVelocityAtTheirGainsAndLags) {
  const Resonator r = simulate_resonator(20000, 3);
  NarxModel m = initialised_model(5);
  const Eigen::VectorXd before = m.net.parameters();
  const FrictionSeed seed = seed_friction_units(m, r.u, r.y, {2.0, 8.0}, 2);
  EXPECT_GT(seed.r_squared, 0.99);

  // the pre-activation of each node over the record; nodes 0, 1: v(k) at gains 2, 8; nodes 2, 3: v(k−1)
  const Eigen::Index n = r.u.size(), inputs = m.net.inputs(), width = 5;
  const Eigen::VectorXd& theta = m.net.parameters();
  Eigen::MatrixXd node(n, 4);
  Eigen::VectorXd x(inputs);
  for (Eigen::Index k = 0; k < n; ++k) {
    m.regressor(r.u, r.y, k, x);
    for (int i = 0; i < 4; ++i) node(k, i) = theta.segment(i * inputs, inputs).dot(x) + theta[width * inputs + i];
  }
  const Eigen::Index settled = 2000;  // the leaky integrator's start-up
  const Eigen::Index m_len = n - settled;
  EXPECT_GT(correlation(node.col(0).tail(m_len), r.v.tail(m_len)), 0.99);
  EXPECT_GT(correlation(node.col(2).tail(m_len), r.v.segment(settled - 1, m_len)), 0.99);
  // one sample earlier is another signal: the v(k−1) node does not follow v(k) as closely
  EXPECT_LT(correlation(node.col(2).tail(m_len), r.v.tail(m_len)), correlation(node.col(2).tail(m_len), r.v.segment(settled - 1, m_len)) - 0.01);
  // unit rms of v̂ times the gain: node 0's pre-activation has rms ≈ 2
  const Eigen::VectorXd centred = node.col(0).tail(m_len).array() - node.col(0).tail(m_len).mean();
  EXPECT_NEAR(std::sqrt(centred.squaredNorm() / static_cast<double>(m_len)), 2.0, 0.1);
  // nodes 1 and 3 are nodes 0 and 2 four times as sharp; node 4 and the other layers are untouched
  for (int i : {0, 2}) {
    const Eigen::VectorXd soft = theta.segment(i * inputs, inputs), sharp = theta.segment((i + 1) * inputs, inputs);
    EXPECT_LT((sharp - 4.0 * soft).norm(), 1e-12 * sharp.norm());
  }
  EXPECT_EQ(theta.segment(4 * inputs, inputs), before.segment(4 * inputs, inputs));
  EXPECT_EQ(theta[width * inputs + 4], before[width * inputs + 4]);
  EXPECT_EQ(theta.tail(theta.size() - width * inputs - width), before.tail(theta.size() - width * inputs - width));
}

TEST(FrictionSeed, BadRequestsNameTheProblem) {
  const Resonator r = simulate_resonator(2000, 4);
  NarxModel m = initialised_model(2);
  const auto message = [&](const std::vector<double>& gains, const Eigen::VectorXd& u, const Eigen::VectorXd& y) {
    try {
      seed_friction_units(m, u, y, gains);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({1.0, 2.0, 3.0}, r.u, r.y).find("3 friction units, but the first hidden layer has 2 nodes"), std::string::npos);
  try {
    seed_friction_units(m, r.u, r.y, {1.0, 2.0}, 2);
    ADD_FAILURE() << "4 nodes on a layer of 2";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("4 friction units"), std::string::npos) << e.what();
  }
  EXPECT_NE(message({0.0}, r.u, r.y).find("gain 0 must be finite and > 0"), std::string::npos);
  EXPECT_NE(message({1.0}, r.u, r.y.head(100)).find("u has 2000 samples, y 100"), std::string::npos);
  Eigen::VectorXd bad = r.y;
  bad[17] = std::nan("");
  EXPECT_NE(message({1.0}, r.u, bad).find("sample 17 is not finite"), std::string::npos);
  EXPECT_NE(message({1.0}, r.u, Eigen::VectorXd::Constant(2000, 0.3)).find("the output is constant"), std::string::npos);
}

}  // namespace
}  // namespace panelbass::models

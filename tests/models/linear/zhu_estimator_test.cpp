// estimate_zhu on a lightly damped 4th-order output-error system with coloured output noise: the
// frequency response against the true one, validation J against the noise floor computed from the
// known noise, and ARX of the same order as the contrast; the choice of H, the steps' wiring, errors.
#include "models/linear/zhu_estimator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <string>

#include "dsp/butterworth.h"
#include "dsp/excitation.h"
#include "dsp/random.h"
#include "models/linear/estimation_error.h"
#include "models/validation/performance.h"
#include "tests/support/expect_error.h"
#include "tests/support/linear_systems.h"

namespace panelbass::models {
namespace {

using testing_support::gaussian;
using testing_support::simulate;

/// Poles 0.97·e^{±j0.3} and 0.9·e^{±j1.2}, B = q⁻¹(0.05 + 0.03q⁻¹ − 0.02q⁻² + 0.01q⁻³).
TransferFunction fourth_order_truth() {
  Eigen::VectorXcd p(4);
  p << std::polar(0.97, 0.3), std::polar(0.97, -0.3), std::polar(0.9, 1.2), std::polar(0.9, -1.2);
  TransferFunction t;
  t.a = polynomial_from_roots(p).tail(4);
  t.b = Eigen::Vector4d(0.05, 0.03, -0.02, 0.01);
  t.nk = 1;
  return t;
}

constexpr double kBandEdge = 0.25;  // input low-pass cutoff, in units of fs

/// One experiment: input with power in [0, 0.25·fs] (uniform noise through a 6th-order Butterworth),
/// output y = G·u + v with v = 0.03·e/(1 − 0.9q⁻¹), e white Gaussian: noise coloured by a filter that
/// shares nothing with G, so an ARX noise model (1/A) cannot describe it.
struct Record {
  Eigen::VectorXd u, y, noise;
};

Record experiment(Eigen::Index N, std::uint64_t seed) {
  Record r;
  dsp::SosFilter lowpass(dsp::butterworth_lowpass(6, kBandEdge, 1.0));
  r.u = lowpass.process(dsp::uniform_noise(static_cast<std::size_t>(N), 1.0, seed));
  TransferFunction colour;
  colour.a = Eigen::VectorXd::Constant(1, -0.9);
  colour.b = Eigen::VectorXd::Constant(1, 0.03);
  r.noise = simulate(colour, gaussian(N, 1.0, seed + 1));
  r.y = simulate(fourth_order_truth(), r.u) + r.noise;
  return r;
}

double db_error(const TransferFunction& model, const TransferFunction& truth, double f) {
  return std::abs(20.0 * std::log10(std::abs(model.response(f, 1.0)) / std::abs(truth.response(f, 1.0))));
}

std::string error_of(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const ModelOrders& o, ZhuOptions opt = {}) {
  return testing_support::message_of<EstimationError>([&] { estimate_zhu(u, y, o, opt); }, "(no error)");
}

TEST(ZhuEstimatorTest, RecoversLightlyDampedSystemUnderColouredNoiseWhereArxFails) {
  const TransferFunction truth = fourth_order_truth();
  const Record est = experiment(20000, 100), val = experiment(20000, 200);
  const ZhuResult zhu = estimate_zhu(est.u, est.y, {4, 4, 1});
  ASSERT_TRUE(zhu.tf.is_stable());
  EXPECT_EQ(zhu.oe.stop_reason, "converged");
  const TransferFunction arx = estimate_arx(est.u, est.y, {4, 4, 1});

  // Frequency response over the band the input excites: within 0.5 dB of the truth; ARX is not.
  double zhu_worst = 0.0, arx_worst = 0.0;
  for (int i = 1; i <= 200; ++i) {
    const double f = kBandEdge * i / 200.0;
    zhu_worst = std::max(zhu_worst, db_error(zhu.tf, truth, f));
    arx_worst = std::max(arx_worst, db_error(arx, truth, f));
  }
  EXPECT_LT(zhu_worst, 0.5);
  EXPECT_GT(arx_worst, 3.0);

  // [2A] on fresh data: the best any model can do is the noise floor Σv²/Σy² (the true G's J).
  const double floor_j = 100.0 * val.noise.squaredNorm() / val.y.squaredNorm();
  const double zhu_j = j_percent(simulate(zhu.tf, val.u), val.y);
  EXPECT_LT(std::abs(zhu_j - floor_j), 0.2 * floor_j) << "Zhu J " << zhu_j << " %, floor " << floor_j << " %";
  ASSERT_TRUE(arx.is_stable());
  const double arx_j = j_percent(simulate(arx, val.u), val.y);
  EXPECT_GT(arx_j, 3.0 * floor_j) << "ARX J " << arx_j << " %, floor " << floor_j << " %";
}

TEST(ZhuEstimatorTest, HighOrderStepIsTheArxOfTheRawDataAndTheFinalModelIsTheOeFit) {
  const Record r = experiment(4000, 300);
  const ZhuResult zhu = estimate_zhu(r.u, r.y, {4, 4, 1});
  const TransferFunction h = estimate_arx(r.u, r.y, {20, 20, 1});
  EXPECT_EQ(zhu.high_order.a, h.a);
  EXPECT_EQ(zhu.high_order.b, h.b);
  EXPECT_EQ(zhu.high_order.nk, 1);
  EXPECT_EQ(zhu.tf.a, zhu.oe.tf.a);
  EXPECT_EQ(zhu.tf.b, zhu.oe.tf.b);
  EXPECT_EQ(zhu.tf.nk, 1);
  EXPECT_EQ(zhu.tf.na(), 4);
  EXPECT_EQ(zhu.tf.nb(), 4);
  EXPECT_LT(zhu.oe.loss, zhu.oe.history.front());
}

TEST(ZhuEstimatorTest, ChoosesHighOrderAutomaticallyOrAsAsked) {
  const Record r = experiment(10000, 400);
  // max(20, 3·na): 20 for na = 4, 24 for na = 8.
  EXPECT_EQ(estimate_zhu(r.u, r.y, {4, 4, 1}).high_order.na(), 20);
  EXPECT_EQ(estimate_zhu(r.u, r.y, {8, 8, 1}).high_order.na(), 24);
  // Capped at N/20 so that the ARX has at most N/10 parameters: N = 300 gives H = 15.
  const Eigen::VectorXd u_short = r.u.head(300), y_short = r.y.head(300);
  const ZhuResult capped = estimate_zhu(u_short, y_short, {4, 4, 1});
  EXPECT_EQ(capped.high_order.na(), 15);
  EXPECT_EQ(capped.high_order.nb(), 15);
  ZhuOptions asked;
  asked.high_order = 30;
  const ZhuResult explicit_h = estimate_zhu(r.u, r.y, {4, 4, 1}, asked);
  EXPECT_EQ(explicit_h.high_order.na(), 30);
  EXPECT_EQ(explicit_h.high_order.nb(), 30);
}

TEST(ZhuEstimatorTest, RejectsUnusableDataWithMessages) {
  const Record r = experiment(1000, 500);
  const ModelOrders o{4, 4, 1};
  EXPECT_EQ(error_of(r.u, r.y.head(999), o), "Zhu(na=4, nb=4, nk=1): the input has 1000 samples but the output has 999");
  Eigen::VectorXd bad = r.u;
  bad[17] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(error_of(bad, r.y, o), "Zhu(na=4, nb=4, nk=1): the input has a non-finite value at sample 17");
  bad = r.y;
  bad[5] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(error_of(r.u, bad, o), "Zhu(na=4, nb=4, nk=1): the output has a non-finite value at sample 5");
  EXPECT_EQ(error_of(Eigen::VectorXd::Ones(1000), r.y, o), "Zhu(na=4, nb=4, nk=1): the input is constant");
  EXPECT_EQ(error_of(r.u.head(60), r.y.head(60), o),
            "Zhu(na=4, nb=4, nk=1): 60 samples are too few for a high-order model of order 4 or more (at most "
            "N/20 = 3)");
  EXPECT_EQ(error_of(r.u, r.y, {-1, 4, 1}), "Zhu(na=-1, nb=4, nk=1): orders must not be negative");
  EXPECT_EQ(error_of(r.u, r.y, {4, 0, 1}), "Zhu(na=4, nb=0, nk=1): nb must be at least 1 (the model needs an input)");
  ZhuOptions low;
  low.high_order = 3;
  EXPECT_EQ(error_of(r.u, r.y, o, low), "Zhu(na=4, nb=4, nk=1): the high order 3 must be at least the model's order 4");
  low.high_order = -2;
  EXPECT_EQ(error_of(r.u, r.y, o, low), "Zhu(na=4, nb=4, nk=1): the high order must not be negative");
}

TEST(ZhuEstimatorTest, NoiseFreeLowOrderDataSaysWhyTheHighOrderStepFails) {
  // Data that satisfy a 4th-order difference equation exactly satisfy every higher one too.
  const Eigen::VectorXd u = dsp::uniform_noise(2000, 1.0, 600);
  const Eigen::VectorXd y = simulate(fourth_order_truth(), u);
  const std::string message = error_of(u, y, {4, 4, 1});
  EXPECT_EQ(message.rfind("Zhu(na=4, nb=4, nk=1): the high-order step failed: ARX(na=20, nb=20, nk=1): the input does "
                          "not excite 40 parameters",
                          0),
            0u)
      << message;
  EXPECT_NE(message.find("use ARX or OE"), std::string::npos) << message;
}

}  // namespace
}  // namespace panelbass::models

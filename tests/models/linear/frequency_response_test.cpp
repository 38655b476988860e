// Frequency responses on a grid against the closed form of a first-order low-pass
// y(k) = p·y(k−1) + (1 − p)·u(k): H(e^{jω}) = (1 − p) / (1 − p·e^{−jω}), so
// |H| = (1 − p) / √(1 − 2p·cos ω + p²) and ∠H = −atan2(p·sin ω, 1 − p·cos ω).

#include "models/linear/frequency_response.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace panelbass::models {
namespace {

constexpr double kResponseFs = 1000.0;
constexpr double kPole = 0.8;

TransferFunction first_order() {
  TransferFunction tf;
  tf.a = Eigen::VectorXd::Constant(1, -kPole);
  tf.b = Eigen::VectorXd::Constant(1, 1.0 - kPole);
  return tf;
}

void expect_first_order(const Eigen::VectorXcd& h, const Eigen::VectorXd& f) {
  ASSERT_EQ(h.size(), f.size());
  for (Eigen::Index k = 0; k < f.size(); ++k) {
    const double w = 2.0 * std::numbers::pi * f[k] / kResponseFs;
    const double magnitude = (1.0 - kPole) / std::sqrt(1.0 - 2.0 * kPole * std::cos(w) + kPole * kPole);
    const double phase = -std::atan2(kPole * std::sin(w), 1.0 - kPole * std::cos(w));
    EXPECT_NEAR(std::abs(h[k]), magnitude, 1e-12) << f[k] << " Hz";
    EXPECT_NEAR(std::arg(h[k]), phase, 1e-12) << f[k] << " Hz";
  }
}

TEST(FrequencyResponse, ATransferFunctionMatchesTheFirstOrderClosedForm) {
  const Eigen::VectorXd f = Eigen::VectorXd::LinSpaced(9, 0.0, 480.0);
  expect_first_order(frequency_response(first_order(), f, kResponseFs), f);
}

TEST(FrequencyResponse, AStateSpaceMatchesTheFirstOrderClosedForm) {
  // x(k+1) = p·x(k) + u(k), y(k) = p(1 − p)·x(k) + (1 − p)·u(k): the same filter.
  StateSpace ss;
  ss.A = Eigen::MatrixXd::Constant(1, 1, kPole);
  ss.B = Eigen::VectorXd::Ones(1);
  ss.C = Eigen::RowVectorXd::Constant(1, kPole * (1.0 - kPole));
  ss.D = 1.0 - kPole;
  const Eigen::VectorXd f = Eigen::VectorXd::LinSpaced(9, 0.0, 480.0);
  expect_first_order(frequency_response(ss, f, kResponseFs), f);
}

TEST(FrequencyResponse, AnEmptyGridGivesAnEmptyResponse) {
  EXPECT_EQ(frequency_response(first_order(), Eigen::VectorXd(), kResponseFs).size(), 0);
}

}  // namespace
}  // namespace panelbass::models

// dsp::leaky_integral against its impulse response in closed form: (1/fs)·λ^k with λ = exp(−2π·corner/fs), the
// corner fs/500 unless given.
#include "dsp/leaky_integral.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace panelbass::dsp {
namespace {

TEST(LeakyIntegral, ItsImpulseResponseDecaysAtItsCorner) {
  const double fs = 3000.0;
  const Eigen::VectorXd impulse = Eigen::VectorXd::Unit(64, 0);
  for (const double corner : {0.0, 50.0, 100.0}) {
    const double lambda = std::exp(-2.0 * std::numbers::pi * (corner > 0.0 ? corner : fs / 500.0) / fs);
    const Eigen::VectorXd h = leaky_integral(impulse, fs, corner);
    for (Eigen::Index k = 0; k < h.size(); ++k) {
      EXPECT_NEAR(h[k], std::pow(lambda, static_cast<double>(k)) / fs, 1e-15) << "corner " << corner << ", sample " << k;
    }
  }
  EXPECT_EQ(leaky_integral(Eigen::VectorXd(), fs).size(), 0);
}

}  // namespace
}  // namespace panelbass::dsp

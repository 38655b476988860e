// The virtual transducer's converters alone (models/plant/converter_loop.h), the input of the process alone.
//
// Independent expectation: a sine's steady state through them has the closed-form response of a zero-order
// hold (gain sinc(f/fs), half a sample of delay), the converters' whole-sample delay, and the two analog
// Butterworth low-passes written from their poles (s_k = ωc·exp(jπ(2k + n − 1)/(2n)), H = Π −s_k/(s − s_k)),
// the output sampled at the end of each sample period as the plant samples its sensor.
#include "models/plant/converter_loop.h"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cmath>
#include <complex>
#include <numbers>

#include "models/plant/plant_presets.h"

namespace panelbass::models {
namespace {

std::complex<double> butterworth_from_poles(int order, double cutoff_hz, double f) {
  const std::complex<double> s(0.0, 2.0 * std::numbers::pi * f);
  const double wc = 2.0 * std::numbers::pi * cutoff_hz;
  std::complex<double> h = 1.0;
  for (int k = 1; k <= order; ++k) {
    const std::complex<double> pole = wc * std::exp(std::complex<double>(0.0, std::numbers::pi * (2 * k + order - 1) / (2.0 * order)));
    h *= -pole / (s - pole);
  }
  return h;
}

TEST(ConverterLoop, ASineComesOutAsTheHoldTheDelayAndBothFiltersSay) {
  models::PlantConfig plant = models::plant_preset("panel-exciter");
  plant.converters.delay_samples = 2;
  plant.converters.ad_filter = {2, 900.0};
  const double fs = plant.fs;
  for (const double f : {100.0, 400.0}) {
    const Eigen::Index n = 6000;
    Eigen::VectorXd u(n);
    for (Eigen::Index k = 0; k < n; ++k) u[k] = std::sin(2.0 * std::numbers::pi * f * static_cast<double>(k) / fs);
    const Eigen::VectorXd l = converters_alone(plant, u);
    // The steady second half fitted by a·sin + b·cos: the response's gain and phase against u(k) = sin(ωkT).
    Eigen::MatrixXd basis(n / 2, 2);
    for (Eigen::Index k = n / 2; k < n; ++k) {
      const double phase = 2.0 * std::numbers::pi * f * static_cast<double>(k) / fs;
      basis(k - n / 2, 0) = std::sin(phase);
      basis(k - n / 2, 1) = std::cos(phase);
    }
    const Eigen::Vector2d ab = basis.colPivHouseholderQr().solve(l.tail(n / 2));
    const std::complex<double> measured(ab[0], ab[1]);
    // Hold: sinc(f/fs) and half a sample; the output sampled a whole sample after the period's start.
    const double x = std::numbers::pi * f / fs;
    const std::complex<double> expected =
        std::sin(x) / x * std::exp(std::complex<double>(0.0, 2.0 * x * (1.0 - 0.5 - plant.converters.delay_samples))) *
        butterworth_from_poles(4, 1200.0, f) * butterworth_from_poles(2, 900.0, f);
    EXPECT_NEAR(std::abs(measured / expected), 1.0, 1e-3) << f << " Hz";
    EXPECT_NEAR(std::arg(measured / expected), 0.0, 1e-3) << f << " Hz";
  }
  plant.converters.da_filter.order = 0;
  plant.converters.ad_filter.order = 0;
  const Eigen::VectorXd pulse = Eigen::VectorXd::Unit(8, 1);
  EXPECT_EQ(converters_alone(plant, pulse), Eigen::VectorXd::Unit(8, 3));  // the delay alone
  Eigen::VectorXd bad = pulse;
  bad[4] = std::nan("");
  EXPECT_THROW(converters_alone(plant, bad), std::invalid_argument);
}

// The sections' layout and equations, written out by hand for a 3rd-order filter after 5 states of something else:
// a second-order section (ω, q = 1) on states 5–6 then a first-order one (ω) on state 7, ω = 2π·1000.
TEST(ConverterLoop, SectionsLayTheirStatesOutInOrderAndFollowTheirEquations) {
  int next = 5;
  const std::vector<ConverterSection> sections = converter_sections({3, 1000.0}, next);
  EXPECT_EQ(next, 8);
  ASSERT_EQ(sections.size(), 2u);
  const double w = 2.0 * std::numbers::pi * 1000.0;
  const ConverterSection &second = sections[0], &first = sections[1];
  EXPECT_FALSE(second.first_order);
  EXPECT_TRUE(first.first_order);
  EXPECT_EQ(second.state, 5);
  EXPECT_EQ(first.state, 7);
  EXPECT_NEAR(second.omega, w, 1e-9 * w);
  EXPECT_NEAR(second.q, 1.0, 1e-12);
  EXPECT_NEAR(first.omega, w, 1e-9 * w);
  Eigen::VectorXd s = Eigen::VectorXd::Zero(8), ds = Eigen::VectorXd::Zero(8);
  s << 9.0, 9.0, 9.0, 9.0, 9.0, 0.3, -0.2, 0.1;
  const double in = 0.7;
  const double out = converter_derivatives(sections, s, in, ds);
  // The second-order section takes the input, the first-order one its output.
  EXPECT_DOUBLE_EQ(ds[5], -0.2);
  EXPECT_NEAR(ds[6], w * w * (in - 0.3) - w * -0.2, 1e-9 * w * w);
  EXPECT_NEAR(ds[7], w * (0.3 - 0.1), 1e-9 * w);
  EXPECT_DOUBLE_EQ(out, 0.1);
  EXPECT_EQ(ds.head(5), Eigen::VectorXd::Zero(5)) << "another's states untouched";
  EXPECT_DOUBLE_EQ(converter_derivatives({}, s, in, ds), in);  // no filter: the input through
}

}  // namespace
}  // namespace panelbass::models

// The process alone's identification: the loopback/sensor pair lagged as documented, and a known process
// recovered from it with the lag added to its delay and its magnitude unchanged.

#include "models/linear/process_alone.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>

#include "dsp/excitation.h"
#include "models/linear/frequency_response.h"
#include "tests/support/linear_systems.h"

namespace panelbass::models {
namespace {

TEST(ProcessAlone, ThePairTakesTheSensorLagSamplesBeforeTheLoopback) {
  const Eigen::VectorXd l = Eigen::VectorXd::LinSpaced(10, 0.0, 9.0);
  const Eigen::VectorXd y = Eigen::VectorXd::LinSpaced(10, 100.0, 109.0);
  const LoopbackPair p = process_alone_pair(l, y);
  ASSERT_EQ(p.l.size(), 10 - kProcessAloneLagSamples);
  ASSERT_EQ(p.y.size(), 10 - kProcessAloneLagSamples);
  for (Eigen::Index k = 0; k < p.l.size(); ++k) {
    EXPECT_EQ(p.l[k], static_cast<double>(k + kProcessAloneLagSamples));  // l(k + lag)
    EXPECT_EQ(p.y[k], 100.0 + static_cast<double>(k));                    // y(k)
  }
  EXPECT_EQ(process_alone_pair(Eigen::VectorXd(), Eigen::VectorXd()).l.size(), 0);
}

TEST(ProcessAlone, AKnownProcessComesBackWithTheLagAddedAndItsMagnitudeUnchanged) {
  // A badly damped second-order process (the thesis's kind) with one sample of delay and offsets on both sides.
  constexpr double kFs = 3000.0;
  TransferFunction process;
  process.a = testing_support::denominator(
      (Eigen::VectorXcd(2) << std::polar(0.97, 0.15), std::polar(0.97, -0.15)).finished());
  process.b = (Eigen::VectorXd(2) << 0.02, 0.015).finished();
  process.nk = 1;
  // The first 1000 samples (the response to the offset's step from rest) left out.
  const Eigen::VectorXd l_all = dsp::uniform_noise(9000, 1.0, 7).array() + 0.3;
  const Eigen::VectorXd l = l_all.tail(8000);
  const Eigen::VectorXd y = testing_support::simulate(process, l_all).tail(8000).array() + 0.1;
  const LoopbackPair est = process_alone_pair(l.head(6000), y.head(6000));
  const LoopbackPair val = process_alone_pair(l.tail(2000), y.tail(2000));

  LinearIdentificationSpec spec;
  spec.method = LinearMethod::oe;
  spec.order = 2;
  spec.fs = kFs;
  const LinearIdentification id = identify_process_alone(est, val, spec);

  EXPECT_EQ(id.model.tf.nk, process.nk + kProcessAloneLagSamples) << id.nk_source;
  EXPECT_LT(id.j_val_pct, 0.01);  // J of the unweighted pair, not of the weighted one
  EXPECT_NEAR(id.model.scaling.u_offset, est.l.mean(), 1e-12);
  EXPECT_NEAR(id.model.scaling.y_offset, est.y.mean(), 1e-12);
  // Within 1 % (0.09 dB) and 10 mrad: the record starts mid-stream, and neither the model nor the weighting
  // knows the state before it, which biases the fit a little.
  for (double f : {10.0, 20.0, 70.0, 200.0, 500.0}) {  // the weighting favours the low end
    const std::complex<double> expected =
        process.response(f, kFs) * std::polar(1.0, -2.0 * std::numbers::pi * f * kProcessAloneLagSamples / kFs);
    const std::complex<double> got =
        id.model.tf.response(f, kFs) * id.model.scaling.y_scale / id.model.scaling.u_scale;  // raw units
    EXPECT_NEAR(std::abs(got / expected), 1.0, 1e-2) << f << " Hz";
    EXPECT_NEAR(std::arg(got / expected), 0.0, 1e-2) << f << " Hz";
  }
}

}  // namespace
}  // namespace panelbass::models

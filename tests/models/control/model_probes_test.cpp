// The evaluation's distortion probes run on the design's NARX plant model: the probe sine, its amplitude
// rule, the model's THD against a DFT written out here, and a controller that changes nothing changing
// nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>

#include "dsp/butterworth.h"
#include "models/control/model_probes.h"
#include "tests/support/narx_models.h"

namespace panelbass::models {
namespace {

constexpr double kProbeFs = 3000.0;

// y(k) = tanh(0.5·y(k−1) + 1.5·u(k)): a saturating plant with odd harmonics.
NarxModel tanh_plant() { return testing_support::one_node_narx(0.5, 1.5, 0.0, 1.0, 0.0, Scaling{}, kProbeFs); }

// A feedforward that passes its input unchanged (L = 0 on a first-order plant), so the probe's drive is the
// probe sine itself.
LqFeedforward pass_through_feedforward() {
  LqFeedforward ff;
  ff.plant.A = Eigen::MatrixXd::Constant(1, 1, 0.5);
  ff.plant.B = Eigen::VectorXd::Ones(1);
  ff.plant.C = Eigen::RowVectorXd::Ones(1);
  ff.plant.D = 0.0;
  ff.L = Eigen::RowVectorXd::Zero(1);
  ff.fs = kProbeFs;
  return ff;
}

// THD in percent of x's harmonics 2..5 against the fundamental f, by a DFT at each harmonic.
double thd_by_dft(const Eigen::VectorXd& x, double f) {
  auto level = [&](int h) {
    std::complex<double> sum = 0.0;
    for (Eigen::Index k = 0; k < x.size(); ++k) {
      sum += x[k] * std::polar(1.0, -2.0 * std::numbers::pi * h * f * static_cast<double>(k) / kProbeFs);
    }
    return std::abs(sum);
  };
  double harmonics = 0.0;
  for (int h = 2; h <= 5; ++h) harmonics += level(h) * level(h);
  return 100.0 * std::sqrt(harmonics) / level(1);
}

TEST(ModelProbes, TheProbeSineFadesInThenHoldsItsAmplitude) {
  const Eigen::VectorXd s = probe_sine(100.0, 0.4, kProbeFs);
  ASSERT_EQ(s.size(), 6000);  // 1 s to settle, 1 s analysed
  const double fade_at_300 = 0.5 - 0.5 * std::cos(std::numbers::pi * 300.0 / 600.0);  // half way through 0.2 s
  EXPECT_NEAR(s[300], fade_at_300 * 0.4 * std::sin(2.0 * std::numbers::pi * 100.0 * 300.0 / kProbeFs), 1e-15);
  EXPECT_NEAR(s[4000 + 7], 0.4 * std::sin(2.0 * std::numbers::pi * 100.0 * 4007.0 / kProbeFs), 1e-12);
  // 30 samples a period: the sampled peak is at 7 of them, sin(2π·7/30)
  EXPECT_NEAR(s.tail(3000).cwiseAbs().maxCoeff(), 0.4 * std::sin(2.0 * std::numbers::pi * 7.0 / 30.0), 1e-12);
}

TEST(ModelProbes, AmplitudeReachesThePeakBehindTheChainsGainAndNeverExceedsIt) {
  const LqFeedforward ff = pass_through_feedforward();
  // unit gain: the peak itself
  EXPECT_NEAR(probe_amplitude({}, ff.controller(), 100.0, kProbeFs, 0.6), 0.6, 1e-12);
  // a band-pass whose gain at 5 Hz is far below 1: still the peak, not more
  const std::vector<dsp::Biquad> bp = dsp::butterworth_bandpass(2, 100.0, 1200.0, kProbeFs);
  EXPECT_NEAR(probe_amplitude(bp, ff.controller(), 5.0, kProbeFs, 0.6), 0.6, 1e-12);
  // a louder controller: A = BL = −2, so x(k+1) = u(k) and u*(k) = u(k) + 2·u(k−1), of gain |1 + 2e^{−jω}|
  LqFeedforward loud = ff;
  loud.plant.A = Eigen::MatrixXd::Constant(1, 1, -2.0);
  loud.L = Eigen::RowVectorXd::Constant(1, -2.0);
  const double w = 2.0 * std::numbers::pi * 100.0 / kProbeFs;
  const double gain = std::abs(1.0 + 2.0 * std::polar(1.0, -w));
  EXPECT_NEAR(probe_amplitude({}, loud.controller(), 100.0, kProbeFs, 0.6), 0.6 / gain, 1e-12);
}

TEST(ModelProbes, ThePlantModelsThdIsTheDftOfItsOwnOutput) {
  const NarxModel plant = tanh_plant();
  const NeuralFeedback fb = NeuralFeedback::with_structure(FeedbackStructure{}, plant);
  const Eigen::VectorXd u = probe_sine(100.0, 0.6, kProbeFs);
  Eigen::VectorXd y(u.size());
  double previous = 0.0;
  for (Eigen::Index k = 0; k < u.size(); ++k) previous = y[k] = std::tanh(0.5 * previous + 1.5 * u[k]);
  const double expected = thd_by_dft(y.tail(3000), 100.0);
  ASSERT_GT(expected, 1.0);  // a saturating plant at this drive: clearly distorted
  EXPECT_NEAR(model_probe_thd_pct(fb, u, false, 3000, 100.0, 5), expected, 1e-9 * expected);
  // N1 = 0 and a drive under the knee: the loop is the plant alone
  EXPECT_NEAR(model_probe_thd_pct(fb, u, true, 3000, 100.0, 5), expected, 1e-9 * expected);
}

TEST(ModelProbes, AControllerThatChangesNothingChangesNoProbe) {
  const NeuralFeedback idle = NeuralFeedback::with_structure(FeedbackStructure{}, tanh_plant());
  const std::vector<double> change = model_thd_change_db(idle, pass_through_feedforward(), {}, {40.0, 100.0, 300.0}, 0.6);
  ASSERT_EQ(change.size(), 3u);
  for (double db : change) EXPECT_NEAR(db, 0.0, 1e-9);
  // a controller that halves the drive (N1 = −50·tanh(0.01·u(k)) ≈ −0.5·u(k)) makes the saturating plant
  // distort less
  NeuralFeedback softer = idle;
  softer.structure = {0, 0, 0, {1}};
  softer.net = Mlp(1, {1});
  softer.net.parameters() << 0.01, 0.0, -0.5 / 0.01, 0.0;  // hidden w, bias, output w, output bias
  const std::vector<double> cut = model_thd_change_db(softer, pass_through_feedforward(), {}, {100.0}, 0.6);
  EXPECT_LT(cut[0], -3.0);
}

TEST(ModelProbes, RefusesProbesItCannotAnalyseAndPeaksOutsideTheRange) {
  const NeuralFeedback idle = NeuralFeedback::with_structure(FeedbackStructure{}, tanh_plant());
  try {
    model_thd_change_db(idle, pass_through_feedforward(), {}, {800.0}, 0.6);
    FAIL() << "a probe above fs/4 was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("800"), std::string::npos) << e.what();
  }
  EXPECT_THROW(model_thd_change_db(idle, pass_through_feedforward(), {}, {100.0}, 0.0), std::invalid_argument);
  EXPECT_THROW(model_thd_change_db(idle, pass_through_feedforward(), {}, {100.0}, 1.5), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

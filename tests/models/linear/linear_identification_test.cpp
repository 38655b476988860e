// Linear identification end to end on the virtual transducer (the Linear issue's "Done when"): the
// linear plant recovered by OE, Zhu and Backx; the panel exciter's order scan and the thesis's point
// that a prediction-error (ARX) fit misleads in simulation; and clear errors for bad input.

#include "models/linear/linear_identification.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "dsp/excitation.h"
#include "dsp/spectrum.h"
#include "models/linear/estimation_error.h"
#include "models/validation/performance.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "tests/support/expect_error.h"
#include "tests/support/linear_systems.h"
#include "tests/support/vectors.h"

namespace panelbass::models {
namespace {

struct Split {
  Eigen::VectorXd u_est, y_est, u_val, y_val, y_val_clean;
};

// `estimation` samples (the thesis: 10 000) then 2 000 validation samples of uniform white noise at
// full drive.
Split make_data(const std::string& preset, std::uint64_t seed, Eigen::Index estimation = 10000) {
  const PlantConfig plant = plant_preset(preset);
  PlantConfig quiet = plant;
  quiet.sensor.noise_rms_V = 0.0;
  const Eigen::VectorXd u = dsp::uniform_noise(static_cast<std::size_t>(estimation) + 2000, 1.0, seed);
  const Eigen::VectorXd y = simulate(plant, u, seed + 100).y;
  const Eigen::VectorXd y_clean = simulate(quiet, u, seed + 100).y;
  return {u.head(estimation), y.head(estimation), u.tail(2000), y.tail(2000), y_clean.tail(2000)};
}

LinearIdentificationSpec spec_for(LinearMethod method, int order) {
  LinearIdentificationSpec spec;
  spec.method = method;
  spec.order = order;
  spec.fs = 3000.0;
  return spec;
}

TEST(LinearIdentification, OeZhuAndBackxRecoverTheLinearPlant) {
  // The true structure: coil 1 + suspension 2 + panel mode 2 + two 4th-order converter filters = 13
  // states, and nk = 1 (the converter's one-sample latency; the first sample after it carries ~1 % of
  // the response, which is why the estimated "visible" delay is 2).
  constexpr int kTrueOrder = 13;
  // At 20 Hz the acceleration lies 31 dB below its plateau and under the sensor noise (SNR ≈ −12.5 dB
  // there). The asymptotic variance of a parametric estimate, var|Ĝ|/|G|² ≈ (n/N)/SNR(ω), gives a
  // standard deviation of 1.3 dB at the thesis's 10 000 samples and 0.3 dB at 200 000 (67 s): only the
  // long record makes "within 1 dB down to 20 Hz" a property of the method rather than of the seed.
  const Split d = make_data("linear", 1, 200000);
  // Reference: the noise-free linear plant's response measured independently by H1 on a long record.
  PlantConfig quiet = plant_preset("linear");
  quiet.sensor.noise_rms_V = 0.0;
  const Eigen::VectorXd u_long = dsp::uniform_noise(1 << 18, 1.0, 77);
  const dsp::FrequencyResponse reference =
      dsp::h1_frf(u_long, simulate(quiet, u_long, 1).y, 3000.0, {4096, 0.5, dsp::Window::hann});
  // The noise floor of the validation data, [2A] with the noise-free output as the "model".
  const double noise_floor = j_percent(d.y_val_clean, d.y_val, 50);

  for (LinearMethod method : {LinearMethod::oe, LinearMethod::zhu, LinearMethod::backx}) {
    SCOPED_TRACE(to_string(method));
    LinearIdentificationSpec spec = spec_for(method, kTrueOrder);
    spec.delay = 1;
    const LinearIdentification id = identify_linear(d.u_est, d.y_est, d.u_val, d.y_val, spec);
    const double gain = id.model.scaling.y_scale / id.model.scaling.u_scale;
    double worst_db = 0.0;
    for (Eigen::Index k = 0; k < reference.frequency.size(); ++k) {
      const double f = reference.frequency[k];
      if (f < 20.0 || f > 1200.0) continue;
      const double model_db = 20 * std::log10(std::abs(id.model.tf.response(f, 3000.0)) * gain);
      const double err = std::abs(model_db - 20 * std::log10(std::abs(reference.h[k])));
      worst_db = std::max(worst_db, err);
    }
    EXPECT_LT(worst_db, 1.0) << "worst magnitude error over 20–1200 Hz";
    EXPECT_LT(id.j_val_pct, 1.2 * noise_floor) << "noise floor " << noise_floor << " %";
    EXPECT_TRUE(id.model.tf.is_stable());
    EXPECT_EQ(id.survey.delay, 2) << "the visible delay estimated from the data";
  }
}

TEST(LinearIdentification, AnEstimatedDelayIsFittedOneLagLaterTooAndTheLowerJKept) {
  // The rule against independent fits: the same data identified with the delay given as the survey's
  // estimate and as one lag more; the automatic run keeps the one whose validation J is lower.
  const Split d = make_data("panel-exciter", 3, 4000);
  LinearIdentificationSpec spec = spec_for(LinearMethod::oe, 8);
  const LinearIdentification automatic = identify_linear(d.u_est, d.y_est, d.u_val, d.y_val, spec);
  ASSERT_TRUE(automatic.survey.delay_found);
  const int estimated = automatic.survey.delay;
  spec.delay = estimated;
  const double j_first = identify_linear(d.u_est, d.y_est, d.u_val, d.y_val, spec).j_val_pct;
  spec.delay = estimated + 1;
  const double j_later = identify_linear(d.u_est, d.y_est, d.u_val, d.y_val, spec).j_val_pct;
  EXPECT_EQ(automatic.model.tf.nk, j_later < j_first ? estimated + 1 : estimated);
  EXPECT_DOUBLE_EQ(automatic.j_val_pct, std::min(j_first, j_later));
  EXPECT_NE(automatic.nk_source.find("lag " + std::to_string(estimated + 1) + " fitted too"), std::string::npos)
      << automatic.nk_source;
}

TEST(LinearIdentification, PanelExciterOrderScanShowsItsKnee) {
  const Split d = make_data("panel-exciter", 1);
  LinearIdentificationSpec spec = spec_for(LinearMethod::zhu, 0);
  spec.scan_from = 1;
  spec.scan_to = 10;
  const LinearIdentification id = identify_linear(d.u_est, d.y_est, d.u_val, d.y_val, spec);
  ASSERT_EQ(id.scan.size(), 10u);
  // Low orders miss the dynamics badly; past the knee (the thesis found 8) J hardly improves.
  EXPECT_GT(id.scan[0].j_val_pct, 50.0);
  EXPECT_LT(id.scan[9].j_val_pct, 8.0);
  EXPECT_GE(id.model.tf.na(), 5);
  EXPECT_LE(id.model.tf.na(), 10);
  double best = 1e9;
  for (const auto& e : id.scan) best = std::min(best, e.j_val_pct);
  const OrderScanEntry& chosen = id.scan[static_cast<std::size_t>(id.model.tf.na() - 1)];
  EXPECT_LE(chosen.j_val_pct, 1.05 * best);
  if (id.model.tf.na() > 1) {
    EXPECT_GT(id.scan[static_cast<std::size_t>(id.model.tf.na() - 2)].j_val_pct, 1.05 * best) << "the rule's smallest order";
  }
}

TEST(LinearIdentification, PanelExciterZhuAndBackxSideBySideAndArxMisleads) {
  const Split d = make_data("panel-exciter", 2);
  const LinearIdentification zhu = identify_linear(d.u_est, d.y_est, d.u_val, d.y_val, spec_for(LinearMethod::zhu, 8));
  const LinearIdentification backx = identify_linear(d.u_est, d.y_est, d.u_val, d.y_val, spec_for(LinearMethod::backx, 8));
  const LinearIdentification arx = identify_linear(d.u_est, d.y_est, d.u_val, d.y_val, spec_for(LinearMethod::arx, 8));
  for (const LinearIdentification* id : {&zhu, &backx}) {
    EXPECT_GT(id->j_val_pct, 1.0);
    EXPECT_LT(id->j_val_pct, 8.0);
  }
  EXPECT_NEAR(zhu.j_val_pct, backx.j_val_pct, 0.25 * zhu.j_val_pct);
  // The thesis's point: PEM's one-step prediction looks good while its simulation is far worse.
  EXPECT_LT(arx.j_pred_est_pct, 0.5 * arx.j_est_pct);
  EXPECT_GT(arx.j_val_pct, 1.5 * zhu.j_val_pct);
}

template <typename Error>
std::string error_of(const std::function<void()>& f) {
  return testing_support::message_of<Error>(f, "(no error)");
}

TEST(LinearIdentification, BadInputGivesClearErrors) {
  const Split d = make_data("linear", 3);
  const Eigen::VectorXd none;
  // Too little data for the order.
  EXPECT_NE(error_of<EstimationError>([&] {
              identify_linear(d.u_est.head(150), d.y_est.head(150), none, none, spec_for(LinearMethod::arx, 80));
            }).find("too few"),
            std::string::npos);
  // A constant input.
  const Eigen::VectorXd constant = Eigen::VectorXd::Constant(5000, 0.3);
  EXPECT_NE(error_of<std::invalid_argument>([&] {
              identify_linear(constant, d.y_est.head(5000), none, none, spec_for(LinearMethod::oe, 4));
            }).find("constant"),
            std::string::npos);
  // Non-finite values name the sample.
  Eigen::VectorXd y = d.y_est;
  y[1234] = std::nan("");
  EXPECT_EQ(error_of<std::invalid_argument>([&] { identify_linear(d.u_est, y, none, none, spec_for(LinearMethod::oe, 4)); }),
            "estimation output: sample 1234 is not finite");
  // A scan without validation data, an empty scan.
  LinearIdentificationSpec scan = spec_for(LinearMethod::zhu, 0);
  scan.scan_from = 1;
  scan.scan_to = 4;
  EXPECT_NE(error_of<std::invalid_argument>([&] { identify_linear(d.u_est, d.y_est, none, none, scan); }).find("--val"),
            std::string::npos);
  // An order beyond what the data supports (Zhu's high-order step needs N/20 ≥ its order).
  EXPECT_NE(error_of<EstimationError>([&] {
              identify_linear(d.u_est.head(400), d.y_est.head(400), none, none, spec_for(LinearMethod::zhu, 30));
            }),
            "(no error)");
}

TEST(LinearIdentification, OrderScanSkipsOrdersNoiseFreeDataCannotSupport) {
  // Noise-free data of a second-order system: from order 3 on, ARX's regressors are linearly dependent
  // (a common factor cancels), so those orders cannot be fitted; the scan goes on without them.
  TransferFunction truth;
  truth.a = testing_support::vec({-1.6, 0.8});
  truth.b = testing_support::vec({0.5, 0.3});
  truth.nk = 1;
  const Eigen::VectorXd u = dsp::uniform_noise(6000, 1.0, 9);
  const Eigen::VectorXd y = testing_support::simulate(truth, u);
  LinearIdentificationSpec scan = spec_for(LinearMethod::arx, 0);
  scan.delay = 1;
  scan.scan_from = 1;
  scan.scan_to = 6;
  const LinearIdentification id = identify_linear(u.head(4000), y.head(4000), u.tail(2000), y.tail(2000), scan);
  ASSERT_EQ(id.scan.size(), 2u);
  EXPECT_EQ(id.scan[0].order, 1);
  EXPECT_EQ(id.scan[1].order, 2);
  ASSERT_EQ(id.scan_skipped.size(), 4u);
  for (std::size_t i = 0; i < id.scan_skipped.size(); ++i) {
    EXPECT_EQ(id.scan_skipped[i].rfind("order " + std::to_string(3 + i) + ": ", 0), 0u) << id.scan_skipped[i];
    // rank-deficient, or a near-cancelling pole-zero pair that the fit leaves unstable
    EXPECT_TRUE(id.scan_skipped[i].find("does not excite") != std::string::npos ||
                id.scan_skipped[i].find("unstable") != std::string::npos)
        << id.scan_skipped[i];
  }
  // The order kept is the true one, with the true poles (the denominator does not depend on the scaling).
  ASSERT_EQ(id.model.tf.a.size(), 2);
  EXPECT_NEAR(id.model.tf.a[0], -1.6, 1e-5);
  EXPECT_NEAR(id.model.tf.a[1], 0.8, 1e-5);
  EXPECT_LT(id.j_val_pct, 1e-3);
  // When no order of the scan can be fitted, the last one's reason is the error.
  scan.scan_from = 3;
  const std::string last = error_of<EstimationError>(
      [&] { identify_linear(u.head(4000), y.head(4000), u.tail(2000), y.tail(2000), scan); });
  EXPECT_TRUE(last.find("does not excite") != std::string::npos || last.find("unstable") != std::string::npos) << last;
}

TEST(LinearIdentification, UnstableArxResultIsAnErrorNotAModel) {
  // A pure integrator-like record: y is the running sum of u, so ARX(1) finds a pole at 1 (or beyond).
  const Eigen::VectorXd u = dsp::uniform_noise(4000, 1.0, 5);
  Eigen::VectorXd y(u.size());
  double acc = 0.0;
  for (Eigen::Index k = 0; k < u.size(); ++k) y[k] = (acc = 1.002 * acc + u[k]);
  const std::string message = error_of<EstimationError>(
      [&] { identify_linear(u, y, Eigen::VectorXd(), Eigen::VectorXd(), spec_for(LinearMethod::arx, 1)); });
  EXPECT_NE(message.find("unstable"), std::string::npos) << message;
}

}  // namespace
}  // namespace panelbass::models

// The mirror filter's observer (an extended Kalman filter on the gray-box exciter model, the sensor as its
// measurement): on a plant its model describes exactly it follows the plant's state, and on a plant whose
// stiffness, force factor or nonlinearity is off it finds the true scales; the sensor map [S1] is recovered from
// its own record.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dsp/excitation.h"
#include "dsp/random.h"
#include "models/control/mirror_filter.h"
#include "models/control/mirror_observer.h"
#include "models/io/config_error.h"
#include "tests/support/expect_error.h"
#include "tests/support/mirror_models.h"

namespace panelbass::models {
namespace {

// [S1] taps of a sensor reading about 2 µV per mm/s² a sample and a half late (a smoothed difference of v)
constexpr std::array<double, 4> kObserverTestTaps{3e-3, 3e-3, -3e-3, -3e-3};

/// The rows of a plant the observer should see: row m+1 = [M1]–[M3] of row m with drive[m − delay], from rest;
/// the sensor's y_k of [S1] on rows k..k−3, plus white noise of rms `noise` (seeded).
struct ObserverTestRecord {
  std::vector<MirrorState> rows;  // rows[m], m = 0..n + delay
  Eigen::VectorXd measured;       // y_k, k = 0..n−1
};

ObserverTestRecord observer_test_record(const MirrorModel& plant, const Eigen::VectorXd& drive, double noise,
                                        std::uint64_t seed) {
  ObserverTestRecord r;
  const Eigen::Index n = drive.size();
  MirrorState s;
  r.rows.push_back(s);
  for (Eigen::Index m = 0; m < n + plant.delay; ++m) {
    step_mirror_model(plant, s, m >= plant.delay ? drive[m - plant.delay] : 0.0);
    r.rows.push_back(s);
  }
  dsp::Rng rng(seed);
  r.measured.resize(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    double y = 0.0;
    for (int j = 0; j < 4; ++j) y += k - j >= 0 ? kObserverTestTaps[static_cast<std::size_t>(j)] * r.rows[static_cast<std::size_t>(k - j)].v : 0.0;
    r.measured[k] = y + noise * rng.gaussian();
  }
  return r;
}

MirrorModel observed_exciter_model(double sensor_noise, double process_noise) {
  MirrorModel m = testing_support::panel_exciter_mirror_model();
  m.delay = 1;
  m.observer.enabled = true;
  m.observer.sensor_taps = kObserverTestTaps;
  m.observer.sensor_noise = sensor_noise;
  m.observer.process_noise = process_noise;
  return m;
}

Eigen::VectorXd observer_test_drive(Eigen::Index n) {
  return (0.8 * dsp::gaussian_noise(n, 0.3, 5)).cwiseMax(-1.0).cwiseMin(1.0);
}

TEST(MirrorObserver, FollowsThePlantsStateOnANoiseFreeExactModel) {
  const MirrorModel model = observed_exciter_model(1e-6, 0.0);
  const Eigen::VectorXd drive = observer_test_drive(6000);
  const ObserverTestRecord rec = observer_test_record(model, drive, 0.0, 1);
  MirrorObserver observer(model);
  double v_scale = 0.0;
  for (const MirrorState& s : rec.rows) v_scale = std::max(v_scale, std::abs(s.v));
  for (Eigen::Index k = 0; k < drive.size(); ++k) {
    observer.predict(drive[k]);
    observer.update(rec.measured[k]);
    // the newest row the observer holds is k + delay + 1
    const MirrorState& truth = rec.rows[static_cast<std::size_t>(k + model.delay + 1)];
    ASSERT_NEAR(observer.state().v, truth.v, 1e-9 * v_scale) << "sample " << k;
    ASSERT_NEAR(observer.state().x, truth.x, 1e-9 * v_scale / model.fs) << "sample " << k;
  }
  EXPECT_NEAR(observer.scales().stiffness, 1.0, 1e-9);
  EXPECT_NEAR(observer.scales().force, 1.0, 1e-9);
  EXPECT_NEAR(observer.scales().nonlinear, 1.0, 1e-9);
}

TEST(MirrorObserver, AdaptsItsScalesToAPlantItsModelDescribesExactly) {
  // the resonance at 0.8 and 1.2 times the model's, the force factor and the nonlinearity 20 % off, and both
  const MirrorScales truths[] = {{0.64, 1.0, 1.0}, {1.44, 1.0, 1.0}, {1.0, 0.8, 1.0}, {1.0, 1.0, 1.2}, {1.44, 1.0, 0.8}};
  for (const MirrorScales& truth : truths) {
    const MirrorModel model = observed_exciter_model(0.02, 1.0);
    const Eigen::VectorXd drive = observer_test_drive(9000);
    const ObserverTestRecord rec = observer_test_record(with_scales(model, truth), drive, 0.02, 2);
    MirrorObserver observer(model);
    double err = 0.0, power = 0.0;
    for (Eigen::Index k = 0; k < drive.size(); ++k) {
      observer.predict(drive[k]);
      observer.update(rec.measured[k]);
      if (k >= 6000) {
        const double v = rec.rows[static_cast<std::size_t>(k + model.delay + 1)].v;
        err += std::pow(observer.state().v - v, 2);
        power += v * v;
      }
    }
    const MirrorScales got = observer.scales();
    const std::string which = "truth " + std::to_string(truth.stiffness) + ", " + std::to_string(truth.force) + ", " +
                              std::to_string(truth.nonlinear);
    EXPECT_NEAR(got.stiffness, truth.stiffness, 0.01 * truth.stiffness) << which;
    EXPECT_NEAR(got.force, truth.force, 0.01 * truth.force) << which;
    EXPECT_NEAR(got.nonlinear, truth.nonlinear, 0.03 * truth.nonlinear) << which;
    EXPECT_LT(std::sqrt(err / power), 0.02) << which;
  }
}

TEST(MirrorObserver, StructuredCovarianceUpdateEqualsTheDenseProduct) {
  // F written out densely (the 3×6 block on rows i, x, v_0, the history's shift, the scales held) and F·P·Fᵀ by
  // Eigen's dense products: the structured update gives the same to rounding
  constexpr int n = MirrorObserver::kStates;
  dsp::Rng rng(7);
  MirrorJacobianBlock block;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 6; ++c) block(r, c) = rng.gaussian();
  }
  MirrorObserver::Matrix root, p, scratch;
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) root(r, c) = rng.gaussian();
  }
  p = root * root.transpose();
  MirrorObserver::Matrix f = MirrorObserver::Matrix::Zero();
  const int columns[] = {0, 1, 2, n - 3, n - 2, n - 1};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 6; ++c) f(r, columns[c]) = block(r, c);
  }
  for (int r = 3; r < n - 3; ++r) f(r, r - 1) = 1.0;
  for (int r = n - 3; r < n; ++r) f(r, r) = 1.0;
  const MirrorObserver::Matrix dense = f * p * f.transpose();
  MirrorObserver::propagate(block, p, scratch);
  EXPECT_LT((p - dense).cwiseAbs().maxCoeff(), 1e-12 * dense.cwiseAbs().maxCoeff());
}

TEST(MirrorObserver, SensorMapFitRecoversTheTapsFromItsOwnRecord) {
  const MirrorModel model = observed_exciter_model(1e-6, 0.0);
  const Eigen::VectorXd drive = observer_test_drive(3000);
  const ObserverTestRecord rec = observer_test_record(model, drive, 0.0, 3);
  // the record's displacement column (m) holds row k at line k
  Eigen::VectorXd displacement(drive.size());
  for (Eigen::Index k = 0; k < drive.size(); ++k) displacement[k] = rec.rows[static_cast<std::size_t>(k)].x / 1000.0;
  // [M3]'s velocity is the displacement's difference, so [S1] on it is what the record's y was made of
  const SensorMapFit fit = fit_sensor_map(displacement, rec.measured, model.fs);
  for (std::size_t j = 0; j < 4; ++j) EXPECT_NEAR(fit.taps[j], kObserverTestTaps[j], 1e-6 * 3e-3) << "tap " << j;
  EXPECT_LT(fit.noise_rms, 1e-6 * rec.measured.cwiseAbs().maxCoeff());
  EXPECT_NE(testing_support::one_line_error<std::invalid_argument>([&] {
              (void)fit_sensor_map(displacement, rec.measured.head(2000), model.fs);
            }).find("same length"),
            std::string::npos);
}

TEST(MirrorObserver, ModelFileKeepsTheObserverAndNamesBadInput) {
  const MirrorModel model = observed_exciter_model(0.07, 50.0);
  const MirrorModel back = mirror_model_from_json(mirror_model_to_json(model));
  EXPECT_TRUE(back.observer.enabled);
  EXPECT_EQ(back.observer.sensor_taps, model.observer.sensor_taps);
  EXPECT_EQ(back.observer.sensor_noise, model.observer.sensor_noise);
  EXPECT_EQ(back.observer.process_noise, model.observer.process_noise);
  EXPECT_FALSE(mirror_model_from_json(mirror_model_to_json(testing_support::panel_exciter_mirror_model())).observer.enabled);
  nlohmann::json bad = mirror_model_to_json(model);
  bad["params"]["observer"]["sensor_taps"].erase(0);
  EXPECT_NE(testing_support::one_line_error<ConfigError>([&] { (void)mirror_model_from_json(bad); })
                .find("model.params.observer.sensor_taps: 4 taps"),
            std::string::npos);
  bad = mirror_model_to_json(model);
  bad["params"]["observer"]["sensor_noise"] = 0.0;
  EXPECT_NE(testing_support::one_line_error<ConfigError>([&] { (void)mirror_model_from_json(bad); })
                .find("model.params.observer.sensor_noise"),
            std::string::npos);
}

}  // namespace
}  // namespace panelbass::models

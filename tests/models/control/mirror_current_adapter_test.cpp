// The mirror filter's adaptation from the coil current (mirror_current_adapter.h): on a plant its model describes
// exactly but for the coil's resistance, Bl(x), K(x) or the nonlinear shapes' scale, it finds the scales the plant was
// made with from the current alone; its settings go through the model file and bad ones are named.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dsp/excitation.h"
#include "dsp/random.h"
#include "models/control/mirror_current_adapter.h"
#include "models/control/mirror_filter.h"
#include "models/io/config_error.h"
#include "tests/support/expect_error.h"
#include "tests/support/mirror_models.h"

namespace panelbass::models {
namespace {

/// panel-exciter's model as the current-only fit has it (no rest inductance: A(z) takes the coil's time constant),
/// adapting from the current `lag` samples behind the drive.
MirrorModel adapted_exciter_model(int lag, double current_noise) {
  MirrorModel m = testing_support::panel_exciter_mirror_model();
  for (std::size_t j : {0u, 2u, 3u}) m.electrical[j] = 0.0;
  m.drive_taps = {1.0, -0.5, 0.1, 0.0};
  m.observer.enabled = true;
  m.observer.measurement = MirrorMeasurement::current;
  m.observer.current_lag = lag;
  m.observer.current_noise = current_noise;
  return m;
}

/// The plant's current, as a record holds it: index k the state before drive[k − lag] acts, plus white noise.
Eigen::VectorXd adapter_test_current(const MirrorModel& plant, const Eigen::VectorXd& drive, int lag, double noise,
                                     std::uint64_t seed) {
  MirrorState s;
  dsp::Rng rng(seed);
  Eigen::VectorXd current(drive.size());
  for (Eigen::Index k = 0; k < drive.size(); ++k) {
    current[k] = s.i + noise * rng.gaussian();
    const Eigen::Index at = k - lag;
    step_mirror_model(plant, s, at >= 0 ? drive[at] : 0.0);
  }
  return current;
}

MirrorScales scales_of(double resistance, double force_factor, double stiffness, double nonlinear) {
  MirrorScales s;
  s.resistance = resistance;
  s.force_factor = force_factor;
  s.stiffness = stiffness;
  s.nonlinear = nonlinear;
  return s;
}

TEST(MirrorCurrentAdapter, FindsTheScalesADriftedPlantWasMadeWith) {
  // the resistance 15 % up (a hot coil), Bl 15 % down, the stiffness 25 % up (the resonance 12 % up), the shapes
  // 20 % stronger, and all four at once in mixed directions; the current with 0.2 % noise; the model without and with
  // an eddy-current branch in [M1] (the scales are found with it; the branch's share of the sensitivities, δj of [A2],
  // is too small here to change them: the test passes without it too)
  const MirrorScales truths[] = {scales_of(1.15, 1.0, 1.0, 1.0), scales_of(1.0, 0.85, 1.0, 1.0),
                                 scales_of(1.0, 1.0, 1.25, 1.0), scales_of(1.0, 1.0, 1.0, 1.2),
                                 scales_of(1.1, 0.85, 0.8, 1.2)};
  const Eigen::VectorXd drive = testing_support::mirror_test_drive(12000, 9);
  for (const bool eddy : {false, true}) {
    for (const MirrorScales& truth : truths) {
      const int lag = 1;
      MirrorModel model = adapted_exciter_model(lag, 1.0);
      if (eddy) model.eddy = {0.6 * model.electrical[4], 1.5};
      const Eigen::VectorXd clean = adapter_test_current(with_scales(model, truth), drive, lag, 0.0, 1);
      const double rms = std::sqrt(clean.squaredNorm() / static_cast<double>(clean.size()));
      const Eigen::VectorXd current = adapter_test_current(with_scales(model, truth), drive, lag, 2e-3 * rms, 1);
      MirrorModel adapting = model;
      adapting.observer.current_noise = 2e-3 * rms;
      MirrorCurrentAdapter adapter(adapting);
      double err = 0.0, power = 0.0;
      for (Eigen::Index k = 0; k < drive.size(); ++k) {
        adapter.push_drive(drive[k]);
        adapter.update(current[k]);
        if (k >= 9000) {
          err += std::pow(adapter.predicted_current() - clean[k], 2);
          power += clean[k] * clean[k];
        }
      }
      const MirrorScales got = adapter.scales();
      const std::string which = std::string(eddy ? "with a branch, " : "") + "truth R " +
                                std::to_string(truth.resistance) + ", Bl " + std::to_string(truth.force_factor) +
                                ", K " + std::to_string(truth.stiffness) + ", N " + std::to_string(truth.nonlinear);
      EXPECT_NEAR(got.resistance, truth.resistance, 0.01 * truth.resistance) << which;
      EXPECT_NEAR(got.force_factor, truth.force_factor, 0.01 * truth.force_factor) << which;
      EXPECT_NEAR(got.stiffness, truth.stiffness, 0.01 * truth.stiffness) << which;
      EXPECT_NEAR(got.nonlinear, truth.nonlinear, 0.05 * truth.nonlinear) << which;
      EXPECT_LT(std::sqrt(err / power), 0.01) << which;
    }
  }
}

TEST(MirrorCurrentAdapter, ItsSettingsGoThroughTheModelFileAndBadOnesAreNamed) {
  const MirrorModel model = adapted_exciter_model(-1, 0.003);
  const MirrorModel back = mirror_model_from_json(mirror_model_to_json(model));
  EXPECT_TRUE(back.observer.enabled);
  EXPECT_EQ(back.observer.measurement, MirrorMeasurement::current);
  EXPECT_EQ(back.observer.current_lag, -1);
  EXPECT_DOUBLE_EQ(back.observer.current_noise, 0.003);
  EXPECT_DOUBLE_EQ(back.observer.scale_rate, model.observer.scale_rate);
  nlohmann::json j = mirror_model_to_json(model);
  j["params"]["observer"]["measurement"] = "laser";
  using testing_support::one_line_error;
  EXPECT_NE(one_line_error<ConfigError>([&] { (void)mirror_model_from_json(j); }).find("model.params.observer.measurement"),
            std::string::npos);
  j = mirror_model_to_json(model);
  j["params"]["observer"]["current_noise_A"] = 0.0;
  EXPECT_NE(one_line_error<ConfigError>([&] { (void)mirror_model_from_json(j); }).find("current_noise_A"), std::string::npos);
  MirrorModel far = model;
  far.observer.current_lag = 9;
  EXPECT_NE(one_line_error<std::invalid_argument>([&] { MirrorCurrentAdapter a(far); }).find("lag of 9"), std::string::npos);
}

}  // namespace
}  // namespace panelbass::models

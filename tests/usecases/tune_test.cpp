#include "usecases/tune.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "models/plant/plant_config.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

// `plant` simulated on each drive, with or without its coil current recorded.
PlayFunction simulated(const models::PlantConfig& plant, bool with_current) {
  return [plant, with_current, seed = std::uint64_t{11}](const Eigen::VectorXd& drive) mutable {
    const models::PlantRecord r = models::simulate(plant, drive, seed++);
    return Playback{r.y, with_current ? r.i : Eigen::VectorXd(), Eigen::VectorXd(), nullptr};
  };
}

// A transducer of tests/support/plants by its file name.
models::PlantConfig support_plant(const std::string& name) {
  return models::load_plant_file(std::string(PANELBASS_SOURCE_DIR) + "/tests/support/plants/" + name + ".json");
}

TuneRequest short_request(double fs) {
  TuneRequest q;
  q.chain.fs = fs;
  q.samples = 12000;
  q.verify.frequencies = {80.0};
  q.verify.levels = {0.2};
  return q;
}

TEST(Tune, KeepsAMirrorFilterFromTheCurrentAloneThatCutsTheDistortion) {
  const models::PlantConfig plant = models::without_sensor_noise(models::plant_preset("panel-exciter"));
  SilentProgress quiet;
  const TuneReport r = tune(short_request(plant.fs), simulated(plant, true), quiet);
  ASSERT_EQ(r.steps.size(), 5u);
  EXPECT_EQ(r.steps[0].name, "measure");
  EXPECT_EQ(r.steps[2].name, "refine");
  EXPECT_EQ(r.steps[4].name, "decide");
  ASSERT_TRUE(r.verify.has_value());
  ASSERT_TRUE(r.verify->points[0].cut_db.has_value()) << r.verify->points[0].unreachable_because;
  // kept exactly when its cut is at least keep_min_cut_db (3 dB) and nowhere below -1 dB: here one point
  EXPECT_EQ(r.keep, *r.verify->points[0].cut_db >= 3.0) << r.decision;
  EXPECT_GT(*r.verify->points[0].cut_db, 3.0) << r.decision;
  EXPECT_EQ(r.decision.rfind("kept", 0), 0u) << r.decision;
  EXPECT_EQ(r.to_json()["left_out"].size(), 2u);  // the LQ feedforward and the neural feedback, each with why
}

TEST(Tune, TheFrictionRefinedOnQuietSinesLiftsTheCutAtLowLevelsToTheIssuesBar) {
  // panel-exciter, quiet, 40 and 80 Hz at program 0.1, where its Coulomb friction dominates the distortion: the
  // multisine fit's friction velocity scale is ~12 % off (the current barely sees it) and the cut stays near 20 dB;
  // refitted on the current's harmonics of two quiet sines it clears issue #56's bar (>= 20 dB at 80 Hz, >= 10 at 40)
  // with room, and by more than the fit alone
  const models::PlantConfig plant = models::without_sensor_noise(models::plant_preset("panel-exciter"));
  SilentProgress quiet;
  TuneRequest q = short_request(plant.fs);
  q.samples = 30000;
  q.verify.frequencies = {40.0, 80.0};
  q.verify.levels = {0.1};
  const auto worst_cut = [](const TuneReport& r) {
    double worst = 1e9;
    for (const EqualOutputPoint& p : r.verify->points) {
      EXPECT_TRUE(p.cut_db.has_value()) << p.frequency_hz << " Hz: " << p.unreachable_because;
      if (p.cut_db) worst = std::min(worst, *p.cut_db);
    }
    return worst;
  };
  q.refine_friction = false;
  const TuneReport fit_only = tune(q, simulated(plant, true), quiet);
  q.refine_friction = true;
  const TuneReport refined = tune(q, simulated(plant, true), quiet);
  ASSERT_EQ(refined.steps[2].name, "refine");
  const nlohmann::json& step = refined.steps[2].summary;
  EXPECT_TRUE(step["used"].get<bool>()) << step.dump();
  EXPECT_LT(step["harmonic_error_after"].get<double>(), 0.99 * step["harmonic_error_before"].get<double>()) << step.dump();
  EXPECT_EQ(step["level"].get<double>(), 0.1);
  const double resonance = refined.mirror->summary["resonance_hz"].get<double>();
  EXPECT_NEAR(step["frequencies_hz"][0].get<double>(), resonance / 4.0, 0.5);  // snapped to the window's bins
  EXPECT_NEAR(step["frequencies_hz"][1].get<double>(), resonance / 2.0, 0.5);
  EXPECT_GT(worst_cut(refined), 25.0);
  EXPECT_GT(worst_cut(refined), worst_cut(fit_only) + 3.0);
  EXPECT_EQ(fit_only.steps.size(), 4u);  // no refine step
}

TEST(Tune, ATransducerWithoutFrictionGetsAFiniteFilter) {
  // no friction to fit: its velocity scale once walked off to infinity and the filter was refused
  models::PlantConfig plant = models::without_sensor_noise(models::plant_preset("panel-exciter"));
  plant.nonlinear.friction.enabled = false;
  SilentProgress quiet;
  TuneRequest q = short_request(plant.fs);
  q.samples = 30000;
  const TuneReport r = tune(q, simulated(plant, true), quiet);
  ASSERT_TRUE(r.verify.has_value()) << r.decision;
  ASSERT_TRUE(r.verify->points[0].cut_db.has_value()) << r.verify->points[0].unreachable_because;
  EXPECT_GT(*r.verify->points[0].cut_db, 20.0) << r.decision;
  EXPECT_TRUE(r.keep) << r.decision;
}

TEST(Tune, AMechanicalResistanceRisingWithVelocityIsFittedAndCutNearTheResonance) {
  // Rms(v) = Rms·(1 + r2·v²) (tests/support/plants, a term the plant has and panel-exciter lacks): at 160 Hz, near the
  // 150 Hz resonance where the velocity peaks, the model without c10 cut the THD at 0.2 by 8.5 dB, under issue #56's
  // 10 dB bar; with it fitted from the current, by 14.5
  const models::PlantConfig plant = models::without_sensor_noise(support_plant("panel-exciter-rms-v"));
  SilentProgress quiet;
  TuneRequest q = short_request(plant.fs);
  q.samples = 30000;
  q.verify.frequencies = {160.0};
  const TuneReport r = tune(q, simulated(plant, true), quiet);
  ASSERT_TRUE(r.mirror.has_value()) << r.decision;
  EXPECT_TRUE(r.mirror->summary["damping_rise"].get<bool>()) << r.mirror->summary.dump();
  ASSERT_TRUE(r.verify.has_value()) << r.decision;
  ASSERT_TRUE(r.verify->points[0].cut_db.has_value()) << r.verify->points[0].unreachable_because;
  EXPECT_GT(*r.verify->points[0].cut_db, 12.0) << r.decision;
}

TEST(Tune, TheRefinedFrictionScaleStaysFiniteWhereTheQuietSinesBarelyShowIt) {
  // second-exciter without its L2R2 branch: the refine's step once walked v0's scale off to infinity there, and the
  // filter file was refused ("friction_velocity_refit: not finite")
  models::PlantConfig plant = models::without_sensor_noise(support_plant("second-exciter"));
  plant.eddy = {};
  SilentProgress quiet;
  TuneRequest q = short_request(plant.fs);
  q.samples = 30000;
  q.verify.levels = {0.1};
  const TuneReport r = tune(q, simulated(plant, true), quiet);
  ASSERT_EQ(r.steps[2].name, "refine");
  const double scale = r.steps[2].summary["friction_velocity_scale"].get<double>();
  EXPECT_TRUE(std::isfinite(scale) && scale > 0.0) << r.steps[2].summary.dump();
  ASSERT_TRUE(r.verify.has_value()) << r.decision;
  ASSERT_TRUE(r.verify->points[0].cut_db.has_value()) << r.verify->points[0].unreachable_because;
  EXPECT_GT(*r.verify->points[0].cut_db, 20.0) << r.decision;
}

TEST(Tune, AnEddyCurrentBranchFoundOnTheQuietSinesLiftsTheCutToTheIssuesBar) {
  // panel-exciter-l2r2 (L2 = 0.4 mH ∥ R2 = 2.5 Ω in series with the coil, Re = 4 Ω, fs 3 kHz): without the branch in
  // [M1] the 80 Hz cut at 0.1 was 18.6 dB, under issue #56's 20; the refine step finds it on the current's harmonics
  // (R2/Re 0.625, h·R2/L2 2.08 in the plant file: the search's grid steps are ×2 in each) and the cut passes the bar
  const models::PlantConfig plant = models::without_sensor_noise(support_plant("panel-exciter-l2r2"));
  SilentProgress quiet;
  TuneRequest q = short_request(plant.fs);
  q.samples = 30000;
  q.verify.levels = {0.1};
  const TuneReport r = tune(q, simulated(plant, true), quiet);
  ASSERT_TRUE(r.mirror.has_value()) << r.decision;
  ASSERT_TRUE(r.mirror->model.eddy.present()) << r.steps[2].summary.dump();
  const double ratio = r.mirror->model.eddy.resistance / r.mirror->model.electrical[4];
  const double rate = r.mirror->model.eddy.rate;
  EXPECT_NEAR(ratio, plant.eddy.R2_ohm / plant.Re_ohm, 0.25 * plant.eddy.R2_ohm / plant.Re_ohm);
  const double plant_rate = plant.eddy.R2_ohm / (plant.eddy.L2_H * plant.fs);
  EXPECT_TRUE(rate > plant_rate / 1.5 && rate < plant_rate * 1.5) << rate << " vs " << plant_rate;
  ASSERT_TRUE(r.verify.has_value()) << r.decision;
  ASSERT_TRUE(r.verify->points[0].cut_db.has_value()) << r.verify->points[0].unreachable_because;
  EXPECT_GT(*r.verify->points[0].cut_db, 20.0) << r.decision;
}

TEST(Tune, ASensorThatHearsNoDistortionKeepsTheFilterUnverifiedAsWithoutOne) {
  // a displacement sensor with its noise: the plant alone is at the floor at every level (the harmonics of x fall as
  // 1/n²), so no cut can be measured — the filter is kept on its fit, as with no sensor, and the decision says why
  const models::PlantConfig plant = support_plant("panel-exciter-displacement");
  SilentProgress quiet;
  TuneRequest q = short_request(plant.fs);
  q.samples = 30000;
  const TuneReport r = tune(q, simulated(plant, true), quiet);
  ASSERT_TRUE(r.verify.has_value()) << r.decision;
  for (const EqualOutputPoint& p : r.verify->points) {
    if (p.reachable) EXPECT_FALSE(EqualOutputReport::credited_cut(p).has_value()) << "the premise: nothing measurable";
  }
  EXPECT_TRUE(r.keep) << r.decision;
  EXPECT_EQ(r.decision.rfind("kept without verification: at every reachable probe level", 0), 0u) << r.decision;
}

TEST(Tune, WithoutASensorTheFilterIsKeptOnTheFitAndSaysItIsUnverified) {
  // Klippel's current-only configuration: the backend records the current (and no sensor), so nothing can measure
  // the cut; the filter joins on the fit, the decision says so, and a sensor asked for is refused
  const models::PlantConfig plant = models::without_sensor_noise(models::plant_preset("panel-exciter"));
  const PlayFunction current_only = [plant, seed = std::uint64_t{3}](const Eigen::VectorXd& drive) mutable {
    const models::PlantRecord r = models::simulate(plant, drive, seed++);
    return Playback{Eigen::VectorXd(), r.i, Eigen::VectorXd(), nullptr};
  };
  SilentProgress quiet;
  TuneRequest q = short_request(plant.fs);
  const TuneReport r = tune(q, current_only, quiet);
  EXPECT_TRUE(r.keep);
  EXPECT_EQ(r.decision.rfind("kept without verification: the backend records no sensor", 0), 0u) << r.decision;
  EXPECT_FALSE(r.verify.has_value());
  ASSERT_EQ(r.steps.size(), 4u);
  EXPECT_EQ(r.steps[2].name, "refine");
  EXPECT_EQ(r.steps[3].name, "decide");
  EXPECT_TRUE(r.to_json()["verify"].is_null());
  q.sensor_kind = "acceleration";
  try {
    (void)tune(q, current_only, quiet);
    ADD_FAILURE() << "a sensor asked of a backend without one was not refused";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("sensor_kind \"acceleration\" asks the fit to read a sensor"), std::string::npos) << e.what();
  }
}

TEST(Tune, TheFitReadsTheDriveItsModelFollowsBestAndTheReportKeepsTheMeasurement) {
  // A card's loopback passes a capture path of its own; the fit is run from the drive as sent and from the loopback,
  // and the model whose current J on validation is lower is kept: a loopback half a sample late, averaged and with a
  // noise of its own loses, and the model is the one fitted without any loopback
  const models::PlantConfig plant = models::without_sensor_noise(models::plant_preset("panel-exciter"));
  const auto current_only = [&plant](bool looped) {
    return PlayFunction([&plant, looped, seed = std::uint64_t{3}](const Eigen::VectorXd& drive) mutable {
      const models::PlantRecord r = models::simulate(plant, drive, seed++);
      Eigen::VectorXd loopback;
      if (looped) {
        loopback = drive;
        for (Eigen::Index k = 1; k < drive.size(); ++k) loopback[k] = 0.5 * (drive[k] + drive[k - 1]) + 1e-3 * std::sin(0.37 * k);
      }
      return Playback{Eigen::VectorXd(), r.i, loopback, nullptr};
    });
  };
  SilentProgress quiet;
  TuneRequest q = short_request(plant.fs);
  q.refine_friction = false;
  const TuneReport plain = tune(q, current_only(false), quiet);
  const TuneReport looped = tune(q, current_only(true), quiet);
  EXPECT_EQ(plain.mirror->summary["drive"], "as sent");
  EXPECT_FALSE(plain.mirror->summary["current_j_val_pct_by_drive"].contains("loopback"));
  const nlohmann::json& by_drive = looped.mirror->summary["current_j_val_pct_by_drive"];
  ASSERT_TRUE(by_drive.contains("loopback")) << by_drive.dump();
  EXPECT_GT(by_drive["loopback"].get<double>(), by_drive["as sent"].get<double>()) << by_drive.dump();
  EXPECT_EQ(looped.mirror->summary["drive"], "as sent");
  for (const char* key : {"current_j_val_pct", "current_lag", "drive_taps", "mechanical", "electrical"}) {
    EXPECT_EQ(looped.mirror->summary[key], plain.mirror->summary[key]) << key;
  }
  // the measurement as played and recorded, for the CLI's --record
  ASSERT_EQ(looped.drive.size(), q.samples);
  EXPECT_NEAR(looped.drive.cwiseAbs().maxCoeff(), q.amplitude, 1e-9);
  const models::PlantRecord again = models::simulate(plant, looped.drive, 3);
  EXPECT_TRUE(looped.measurement.current.isApprox(again.i));
  EXPECT_EQ(looped.measurement.loopback.size(), q.samples);
}

TEST(Tune, ALoopbackThatIsWhatThePlantReceivedIsTheFitsDrive) {
  // the other way round: the plant is driven through a filter the three drive taps cannot follow (a card's
  // reconstruction with a ringing tail), and the loopback records what reached it: the loopback's model follows the
  // current better, and the fit takes it
  const models::PlantConfig plant = models::without_sensor_noise(models::plant_preset("panel-exciter"));
  const PlayFunction play = [&plant, seed = std::uint64_t{5}](const Eigen::VectorXd& drive) mutable {
    Eigen::VectorXd received = drive;
    // a resonance near 420 Hz, DC gain 0.6 / (1 - 0.9 + 0.5) = 1
    for (Eigen::Index k = 2; k < drive.size(); ++k) received[k] = 0.6 * drive[k] + 0.9 * received[k - 1] - 0.5 * received[k - 2];
    const models::PlantRecord r = models::simulate(plant, received, seed++);
    return Playback{Eigen::VectorXd(), r.i, received, nullptr};
  };
  SilentProgress quiet;
  TuneRequest q = short_request(plant.fs);
  q.refine_friction = false;
  q.amplitude = 0.3;
  const TuneReport r = tune(q, play, quiet);
  const nlohmann::json& by_drive = r.mirror->summary["current_j_val_pct_by_drive"];
  EXPECT_LT(by_drive["loopback"].get<double>(), by_drive["as sent"].get<double>()) << by_drive.dump();
  EXPECT_EQ(r.mirror->summary["drive"], "loopback");
  EXPECT_EQ(r.mirror->summary["current_j_val_pct"], by_drive["loopback"]);
}

TEST(Tune, ABackendWithoutTheCoilCurrentIsToldWhatIsMissing) {
  const models::PlantConfig plant = models::plant_preset("panel-exciter");
  SilentProgress quiet;
  try {
    (void)tune(short_request(plant.fs), simulated(plant, false), quiet);
    FAIL() << "tuned without a current";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no coil current"), std::string::npos) << e.what();
  }
}

TEST(Tune, ARequestOutOfRangeNamesItsField) {
  TuneRequest q = short_request(3000.0);
  q.safe_level = 0.4;
  q.amplitude = 0.5;
  try {
    check(q);
    FAIL() << "accepted an amplitude beyond the safe level";
  } catch (const RequestError& e) {
    EXPECT_EQ(e.field(), "amplitude");
  }
  q = short_request(3000.0);
  q.sensor_kind = "laser";
  try {
    check(q);
    FAIL() << "accepted an unknown sensor";
  } catch (const RequestError& e) {
    EXPECT_EQ(e.field(), "sensor_kind");
  }
}

}  // namespace
}  // namespace panelbass::usecases

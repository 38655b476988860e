#include "usecases/tune.h"

#include <gtest/gtest.h>

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
    return Playback{r.y, with_current ? r.i : Eigen::VectorXd(), Eigen::VectorXd()};
  };
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
  ASSERT_EQ(r.steps.size(), 4u);
  EXPECT_EQ(r.steps[0].name, "measure");
  EXPECT_EQ(r.steps[3].name, "decide");
  ASSERT_TRUE(r.verify.has_value());
  ASSERT_TRUE(r.verify->points[0].cut_db.has_value()) << r.verify->points[0].unreachable_because;
  // kept exactly when its cut is at least keep_min_cut_db (3 dB) and nowhere below -1 dB: here one point
  EXPECT_EQ(r.keep, *r.verify->points[0].cut_db >= 3.0) << r.decision;
  EXPECT_GT(*r.verify->points[0].cut_db, 3.0) << r.decision;
  EXPECT_EQ(r.decision.rfind("kept", 0), 0u) << r.decision;
  EXPECT_EQ(r.to_json()["left_out"].size(), 2u);  // the LQ feedforward and the neural feedback, each with why
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

#include "usecases/design_nn.h"

#include <gtest/gtest.h>

#include "models/plant/plant_presets.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

// The field and the words a request is refused with ("" when it is not).
std::pair<std::string, std::string> refusal(const DesignNnRequest& q) {
  try {
    check(q);
  } catch (const RequestError& e) {
    return {e.field(), e.problem()};
  }
  return {"", ""};
}

TEST(DesignNn, TheDefaultsAreTheModelsAndTheRequestEchoesThemAsTheApiNamesThem) {
  const DesignNnRequest q;
  EXPECT_EQ(refusal(q).first, "");
  const nlohmann::json fields = to_json(q);
  const models::FeedbackDesignOptions design;
  EXPECT_EQ(fields.at("samples"), design.samples);
  EXPECT_EQ(fields.at("max_iterations"), design.training.max_iterations);
  EXPECT_EQ(fields.at("hidden"), nlohmann::json(design.structure.hidden));
  EXPECT_EQ(fields.at("weighting"), "none");
  EXPECT_EQ(fields.at("tune_on"), "none");
  EXPECT_EQ(fields.at("tune_playbacks"), 1);
  EXPECT_TRUE(fields.at("band_pass").is_null());
  EXPECT_TRUE(fields.at("start_from").is_null());
}

TEST(DesignNn, ARequestOutOfRangeOrInconsistentNamesItsField) {
  DesignNnRequest q;
  q.design.structure.nu = 101;
  EXPECT_EQ(refusal(q), std::make_pair(std::string("nu"), std::string("must be an integer in [0, 100], got 101")));
  q = DesignNnRequest{};
  q.design.sine_peak = 0.0;
  EXPECT_EQ(refusal(q), std::make_pair(std::string("sine_peak"), std::string("must be a number in (0, 1], got 0")));
  q = DesignNnRequest{};
  q.design.structure.hidden = {};
  EXPECT_EQ(refusal(q).first, "hidden");
  q = DesignNnRequest{};
  q.design.device_playbacks = 2;
  EXPECT_EQ(refusal(q).first, "tune_playbacks") << "playbacks without a device";
  q = DesignNnRequest{};
  q.tune_on = models::plant_preset("linear");
  EXPECT_EQ(refusal(q).first, "tune_on") << "tuning on a device needs the plant-fundamental target";
  q.design.desired = models::DesiredResponse::plant_fundamental;
  EXPECT_EQ(refusal(q).first, "");
  q = DesignNnRequest{};
  q.start_from = "fb.json";
  q.design.restarts = 2;
  EXPECT_EQ(refusal(q).first, "start_from");
  q = DesignNnRequest{};
  q.design.level_weighting = q.design.distortion_weighting = true;
  EXPECT_EQ(refusal(q).first, "weighting");
}

TEST(DesignNn, AModelFileOfTheWrongKindIsRefusedNamingItsField) {
  DesignNnRequest q;
  q.plant_model = {{"format", "panelbass.model/1"}, {"kind", "linear"}};
  q.plant_name = "lin.json";
  SilentProgress quiet;
  try {
    design_nn(q, quiet);
    FAIL() << "a linear plant model was taken";
  } catch (const RequestError& e) {
    EXPECT_EQ(e.field(), "plant_model");
    EXPECT_EQ(e.problem(), "expected a NARX or state-space (ss) model, got linear");
  }
}

}  // namespace
}  // namespace panelbass::usecases

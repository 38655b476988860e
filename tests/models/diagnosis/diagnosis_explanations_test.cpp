// explain(): the sentences a diagnosis finding carries name the physical quantity its term acts on and say
// nothing empty (a level ratio of about 1 is no level dependence).

#include "models/diagnosis/diagnosis_explanations.h"
#include "tests/support/text.h"

#include <gtest/gtest.h>

#include <string>

namespace panelbass::models::diagnosis_detail {
namespace {

using testing_support::contains;

TEST(DiagnosisExplanations, StiffnessNamesTheDisplacementItActsOn) {
  Candidate c;
  c.effect = Effect::cubic_stiffness;
  c.parameters_json = {{"state", "integral"}};
  const std::string text = explain(c, ResidualLocation{}, 0.4);
  EXPECT_TRUE(contains(text, "standing in for the displacement")) << text;
  EXPECT_FALSE(contains(text, "(a velocity")) << "stiffness acts on displacement: " << text;
  c.parameters_json = {{"state", "double_integral"}};
  EXPECT_TRUE(contains(explain(c, ResidualLocation{}, 0.4), "double integral of the output (the displacement"));
  c.effect = Effect::hysteresis;  // friction acts on the velocity: the integral is what it needs
  c.parameters_json = {{"state", "integral"}};
  EXPECT_TRUE(contains(explain(c, ResidualLocation{}, 0.4), "(the velocity, for an accelerometer)"));
}

TEST(DiagnosisExplanations, ALevelRatioNearOneIsNotReportedAsALevelDependence) {
  Candidate c;
  c.effect = Effect::saturation;
  c.parameters_json = {{"knee_fraction_of_peak", 0.9}, {"one_sided", false}};
  ResidualLocation where;
  where.level_ratio = 1.04;
  const std::string flat = explain(c, where, 0.3);
  EXPECT_FALSE(contains(flat, "times larger")) << flat;
  EXPECT_TRUE(contains(flat, "beyond 90 % of its peak.")) << flat;
  where.level_ratio = 2.5;
  EXPECT_TRUE(contains(explain(c, where, 0.3), "2.5 times larger at high input level")) << explain(c, where, 0.3);
}

}  // namespace
}  // namespace panelbass::models::diagnosis_detail

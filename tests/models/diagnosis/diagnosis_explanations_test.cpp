// explain(): the sentences a diagnosis finding carries name the physical quantity its term acts on and say
// nothing empty (a level ratio of about 1 is no level dependence); a saturation behind the drive's filter says so.

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

// A saturation behind the drive's filter says where it sits: the filter before the clip, the resonances after it.
TEST(DiagnosisExplanations, ASaturationBehindTheDrivesFilterSaysWhereItSits) {
  Candidate c;
  c.effect = Effect::saturation;
  c.parameters_json = {{"knee_fraction_of_peak", 0.8}, {"one_sided", false}, {"structure", "Hammerstein"}};
  EXPECT_FALSE(contains(explain(c, ResidualLocation{}, 0.3), "filter")) << explain(c, ResidualLocation{}, 0.3);
  c.parameters_json["structure"] = "Hammerstein behind the drive's filter";
  c.parameters_json["front_order"] = 1;
  const std::string text = explain(c, ResidualLocation{}, 0.3);
  EXPECT_TRUE(contains(text, "through a filter of the drive (1 pole before the clip")) << text;
  EXPECT_TRUE(contains(text, "beyond 80 % of its peak.")) << text;
}

}  // namespace
}  // namespace panelbass::models::diagnosis_detail

// The "mimo" model file: a model written and read back is the same model, and a wrong file is refused
// naming the key and what is wrong with it; the single-input loader refuses the kind by name.
#include "models/linear/mimo_model.h"

#include <gtest/gtest.h>

#include "models/io/config_error.h"
#include "models/kinds/model_file.h"
#include "tests/support/expect_error.h"
#include "tests/support/mimo_systems.h"

namespace panelbass::models {
namespace {

MimoModel example() {
  MimoModel m;
  m.ss = testing_support::mimo_system({{0.9, 0.3}, {0.5, 2.0}}, 2, 3, 7);
  m.fs = 6400.0;
  m.inputs = {"u1", "u2"};
  m.outputs = {"y1", "y2", "y3"};
  m.meta = {{"method", "fir-kung-oe"}};
  return m;
}

std::string refusal(const nlohmann::json& j) {
  return testing_support::one_line_error<ConfigError>([&] { mimo_model_from_json(j); });
}

TEST(MimoModelTest, RoundTripsThroughJson) {
  const MimoModel m = example();
  const MimoModel back = mimo_model_from_json(nlohmann::json::parse(mimo_model_to_json(m).dump()));
  EXPECT_EQ(back.fs, m.fs);
  EXPECT_EQ(back.inputs, m.inputs);
  EXPECT_EQ(back.outputs, m.outputs);
  EXPECT_EQ(back.ss.A, m.ss.A);
  EXPECT_EQ(back.ss.B, m.ss.B);
  EXPECT_EQ(back.ss.C, m.ss.C);
  EXPECT_EQ(back.ss.D, m.ss.D);
  EXPECT_EQ(back.meta, m.meta);
}

TEST(MimoModelTest, WrongFilesAreRefusedNamingWhatIsWrong) {
  const nlohmann::json good = mimo_model_to_json(example());
  nlohmann::json j = good;
  j["params"]["B"][1] = {0.5};
  EXPECT_NE(refusal(j).find("model.params.B[1]: expected 2 numbers, got 1"), std::string::npos) << refusal(j);
  j = good;
  j["params"]["C"].erase(2);
  EXPECT_NE(refusal(j).find("model.params.C: expected 3 rows, got 2"), std::string::npos) << refusal(j);
  j = good;
  j.erase("outputs");
  EXPECT_NE(refusal(j).find("model.outputs: missing"), std::string::npos) << refusal(j);
  j = good;
  j["inputs"] = {"u1", "u1"};
  EXPECT_NE(refusal(j).find("model.inputs[1]: duplicate name"), std::string::npos) << refusal(j);
  j = good;
  j["params"]["A"] = {{1.1, 0, 0, 0}, {0, 0.5, 0, 0}, {0, 0, 0.5, 0}, {0, 0, 0, 0.5}};
  EXPECT_NE(refusal(j).find("model: unstable, pole radius 1.1"), std::string::npos) << refusal(j);
  j = good;
  j["params"]["D"][0][0] = "x";
  EXPECT_NE(refusal(j).find("model.params.D[0][0]: expected a number"), std::string::npos) << refusal(j);
  // The loader of single-input models names the kind rather than misreading it.
  const std::string any = testing_support::one_line_error<ConfigError>([&] { model_from_json(good); });
  EXPECT_NE(any.find("\"mimo\" is a multi-input multi-output model"), std::string::npos) << any;
}

}  // namespace
}  // namespace panelbass::models

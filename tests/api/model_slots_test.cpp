// Which model runs in which slot, through the real server: the feedforward slot runs an LQ feedforward
// controller or a mirror filter, the feedback slot a neural feedback controller, and a plant model runs in
// none — refused by activation, by the config and by a job's activate flag, each saying the model's kind and
// what the slot takes — and the model list says which slots take each model. Also: a stored model uploaded
// again under a new name is renamed.
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "models/diagnosis/gray_box_model.h"
#include "models/kinds/model_file.h"
#include "models/linear/linear_model.h"
#include "models/narx/narx_model.h"
#include "models/oscillator/oscillator_model.h"
#include "tests/api/server_fixture.h"
#include "tests/support/mirror_models.h"
#include "tests/support/ss_models.h"

namespace panelbass::api {
namespace {

using namespace api_testing;

TEST_F(ServerTest, EachSlotRunsItsControllerKindAndAPlantModelRunsInNone) {
  start();
  const std::string linear = upload(models::linear_model_to_json(engine::testing::example_linear()));
  const std::string narx = upload(models::narx_model_to_json(engine::testing::example_narx(32)));
  const std::string lq = upload(lq_gain_controller(0.5));
  const std::string nn = upload(zero_feedback_controller(32));

  // The list says where each can go.
  const nlohmann::json expected_slots = {{linear, nlohmann::json::array()},
                                         {narx, nlohmann::json::array()},
                                         {lq, {"feedforward"}},
                                         {nn, {"feedback"}}};
  const Reply list = get("/api/models");
  ASSERT_EQ(list.body["models"].size(), 4u) << list.text;
  for (const nlohmann::json& m : list.body["models"]) EXPECT_EQ(m["slots"], expected_slots[m["id"].get<std::string>()]) << m;

  // A plant model: 409 naming its kind and what the slot takes.
  const Reply plant = post("/api/models/" + linear + "/activate", std::string());
  EXPECT_EQ(plant.status, 409) << plant.text;
  EXPECT_EQ(plant.body["error"]["code"], "conflict");
  EXPECT_NE(error_message(plant).find("is a linear plant model (kind linear)"), std::string::npos) << plant.text;
  EXPECT_NE(error_message(plant).find("the feedforward slot takes lq_feedforward or mirror_filter"), std::string::npos)
      << plant.text;
  const Reply narx_feedback = post("/api/models/" + narx + "/activate", nlohmann::json{{"slot", "feedback"}});
  EXPECT_EQ(narx_feedback.status, 409) << narx_feedback.text;
  EXPECT_NE(error_message(narx_feedback).find("NARX plant model"), std::string::npos) << narx_feedback.text;
  EXPECT_NE(error_message(narx_feedback).find("the feedback slot takes neural_feedback"), std::string::npos) << narx_feedback.text;
  // A controller in the other slot.
  const Reply lq_feedback = post("/api/models/" + lq + "/activate", nlohmann::json{{"slot", "feedback"}});
  EXPECT_EQ(lq_feedback.status, 409) << lq_feedback.text;
  EXPECT_NE(error_message(lq_feedback).find("it goes in the feedforward slot"), std::string::npos) << lq_feedback.text;
  // Nothing changed.
  nlohmann::json active = get("/api/status").body["active_models"];
  EXPECT_TRUE(active["feedforward"].is_null()) << active;
  EXPECT_TRUE(active["feedback"].is_null()) << active;

  // The config refuses them too, naming the key.
  const Reply config = patch("/api/config", nlohmann::json{{"feedforward", {{"model", linear}}}}.dump());
  EXPECT_EQ(config.status, 409) << config.text;
  EXPECT_NE(error_message(config).find("config.feedforward.model: model \"" + linear + "\" is a linear plant model"),
            std::string::npos)
      << config.text;

  // Each controller goes to its own slot by default.
  const Reply ff = post("/api/models/" + lq + "/activate", std::string());
  ASSERT_EQ(ff.status, 200) << ff.text;
  EXPECT_EQ(ff.body["slot"], "feedforward");
  const Reply fb = post("/api/models/" + nn + "/activate", std::string());
  ASSERT_EQ(fb.status, 200) << fb.text;
  EXPECT_EQ(fb.body["slot"], "feedback");
  active = get("/api/status").body["active_models"];
  EXPECT_EQ(active, (nlohmann::json{{"feedforward", lq}, {"feedback", nn}}));
}

// A model file of each kind a verb writes, at the engine's rate: identify linear, narx, ss and oscillator,
// diagnose --model-out (gray_box), design lq, design mirror and design nn.
std::map<std::string, nlohmann::json> one_model_of_each_kind() {
  const double fs = engine::testing::kFs;
  models::GrayBoxModel gray;
  gray.augmented.linear = engine::testing::example_linear();
  gray.fs = fs;
  models::OscillatorModel osc;
  osc.structure.terms = {models::OscillatorTerm::y3};
  osc.theta = Eigen::VectorXd::Zero(osc.structure.parameter_count());
  osc.theta(models::kOscDamping) = 0.05;
  osc.theta(models::kOscStiffness) = 0.04;
  osc.theta(models::kOscGain) = 0.04;
  osc.theta(osc.structure.term_index(0)) = 0.01;
  osc.scaling = {0.0, 1.0, 0.0, 1.0};
  osc.fs = fs;
  return {{"linear", models::linear_model_to_json(engine::testing::example_linear())},
          {"narx", models::narx_model_to_json(engine::testing::example_narx(32))},
          {"ss", models::ss_model_to_json(testing_support::resonant_ss(200.0, fs, 0.1, 0.0, 0.5, 0.0, 0.0,
                                                                        {0.0, 1.0, 0.0, 1.0}, 1))},
          {"oscillator", models::oscillator_model_to_json(osc)},
          {"gray_box", models::gray_box_model_to_json(gray)},
          {"lq_feedforward", lq_gain_controller(0.5)},
          {"mirror_filter", models::mirror_model_to_json(testing_support::panel_exciter_mirror_model())},
          {"neural_feedback", zero_feedback_controller(32)}};
}

// Every kind the registry knows is one a verb writes, and POST /api/models stores each; the slots each summary
// lists are the registry's, and each controller activates into its slot (the mirror filter into the feedforward
// slot, as the LQ controller) while a plant model is refused by both.
TEST_F(ServerTest, EveryKindAVerbWritesIsStoredAndEachControllerActivatesIntoItsSlot) {
  start();
  const std::map<std::string, nlohmann::json> files = one_model_of_each_kind();
  ASSERT_EQ(files.size(), models::model_kinds().size()) << "a kind of the registry has no example here";
  const std::map<std::string, nlohmann::json> slots = {
      {"linear", nlohmann::json::array()},   {"narx", nlohmann::json::array()},
      {"ss", nlohmann::json::array()},       {"oscillator", nlohmann::json::array()},
      {"gray_box", nlohmann::json::array()}, {"lq_feedforward", {"feedforward"}},
      {"mirror_filter", {"feedforward"}},    {"neural_feedback", {"feedback"}}};
  for (const auto& [kind, file] : files) {
    const Reply stored = post("/api/models", file);
    ASSERT_EQ(stored.status, 201) << kind << ": " << stored.text;
    EXPECT_EQ(stored.body["kind"], kind);
    EXPECT_EQ(stored.body["slots"], slots.at(kind)) << kind;
    const std::string id = stored.body["id"];
    const Reply activated = post("/api/models/" + id + "/activate", std::string());
    if (slots.at(kind).empty()) {
      EXPECT_EQ(activated.status, 409) << kind << ": " << activated.text;
      continue;
    }
    ASSERT_EQ(activated.status, 200) << kind << ": " << activated.text;
    EXPECT_EQ(activated.body["slot"], slots.at(kind)[0]) << kind;
    const std::string other = slots.at(kind)[0] == "feedforward" ? "feedback" : "feedforward";
    EXPECT_EQ(post("/api/models/" + id + "/activate", nlohmann::json{{"slot", other}}).status, 409) << kind;
    EXPECT_EQ(get("/api/status").body["active_models"][slots.at(kind)[0].get<std::string>()], id) << kind;
  }
}

TEST_F(ServerTest, AJobAsksToActivateOnlyAModelASlotRuns) {
  start();
  const Reply identify = post("/api/jobs", nlohmann::json{{"kind", "identify-linear"}, {"activate", true}});
  EXPECT_EQ(identify.status, 400) << identify.text;
  EXPECT_NE(error_message(identify).find("activate: the job kind identify-linear makes a linear plant model, which no slot runs"),
            std::string::npos)
      << identify.text;
  const Reply excite = post("/api/jobs", nlohmann::json{{"kind", "excite"}, {"activate", true}});
  EXPECT_EQ(excite.status, 400) << excite.text;
  EXPECT_NE(error_message(excite).find("makes no model to activate"), std::string::npos) << excite.text;
  EXPECT_EQ(get("/api/jobs").body["jobs"].size(), 0u);
}

TEST_F(ServerTest, AStoredModelUploadedAgainUnderANewNameIsRenamedAndKeepsItsNameWithoutOne) {
  const std::filesystem::path store = dir_ / "store";
  start(options(store));
  const nlohmann::json model = lq_gain_controller(0.5);
  ASSERT_EQ(post("/api/models?name=first", model).status, 201);
  const Reply renamed = post("/api/models?name=second", model);
  EXPECT_EQ(renamed.status, 200) << renamed.text;
  EXPECT_EQ(renamed.body["name"], "second");
  const Reply unnamed = post("/api/models", model);
  EXPECT_EQ(unnamed.status, 200) << unnamed.text;
  EXPECT_EQ(unnamed.body["name"], "second");
  EXPECT_EQ(get("/api/models").body["models"][0]["name"], "second");
  // On disk too: a restart reads the new name back.
  server_->stop();
  start(options(store));
  EXPECT_EQ(get("/api/models").body["models"][0]["name"], "second");
}

}  // namespace
}  // namespace panelbass::api

// The design-lq and design-nn jobs: a stable LQ controller (by R or by max_input), and a neural feedback
// controller trained behind it (lags, tuning on a device, restarts).

#include <gtest/gtest.h>

#include "models/control/loop_plant.h"
#include "models/state_space_nn/ss_model.h"
#include "tests/api/jobs/job_test_fixture.h"
#include "tests/support/ss_models.h"

namespace panelbass::api::job_testing {
namespace {

TEST_F(JobKindsTest, DesignLqMakesAStableControllerThatLoads) {
  const std::string plant = store_reference_model();
  FakeControl control("j3");
  const json result = run("design-lq", {{"plant_model", plant}, {"r", 3.0}, {"band_pass", {{"low_hz", 0}, {"high_hz", 1000}}}}, control);
  expect_progress(control);
  const std::string id = result.at("model_id").get<std::string>();
  ASSERT_TRUE(store_->find(id));
  EXPECT_EQ(store_->find(id)->kind, "lq_feedforward");
  const models::LqFeedforward ff = models::lq_feedforward_from_json(*store_->model(id));
  EXPECT_LT(ff.poles().cwiseAbs().maxCoeff(), 1.0);
  EXPECT_DOUBLE_EQ(ff.weights.R, 3.0);
  EXPECT_EQ(ff.meta.at("model"), plant);
  EXPECT_EQ(ff.meta.at("bandpass"), json({0.0, 1000.0}));
  EXPECT_GT(result.at("summary").at("max_input_noise").get<double>(), 0.0);
  // The drive's peak gain: at least the gain anywhere else, at most ‖h‖₁ = 1/max_input_worst.
  const double peak_db = result.at("summary").at("drive_peak").at("gain_db").get<double>();
  const dsp::SosFilter band(dsp::butterworth_band(2, 0.0, 1000.0, kFs));
  for (const double f : {5.0, 50.0, 150.0, 400.0, 900.0}) {
    EXPECT_LE(20.0 * std::log10(std::abs(band.response(f, kFs) * models::response(ff.controller(), f, kFs))), peak_db + 1e-9)
        << f << " Hz";
  }
  EXPECT_LE(peak_db, -20.0 * std::log10(result.at("summary").at("max_input_worst").get<double>()) + 1e-9);
  EXPECT_EQ(result.at("summary").at("unity_gain_hz"), json(models::unity_gain_hz(ff)));
  expect_plot(result.at("plots").at("spectrum"), {"f", "plant_db", "controlled_db", "controller_db"});
  // The plant's magnitude peaks at its resonance.
  const json& s = result.at("plots").at("spectrum");
  std::size_t top = 0;
  for (std::size_t k = 0; k < s.at("f").size(); ++k) {
    if (s.at("plant_db")[k].get<double>() > s.at("plant_db")[top].get<double>()) top = k;
  }
  EXPECT_NEAR(s.at("f")[top].get<double>(), kResonanceHz, 30.0);
}


TEST_F(JobKindsTest, DesignLqByMaxInputSearchesTheFlattestWeightThatAllowsIt) {
  const std::string plant = store_reference_model();
  const auto safe_amplitude = [&](double r, const std::string& job) {
    return run("design-lq", {{"plant_model", plant}, {"r", r}}, job).at("summary").at("max_input_noise").get<double>();
  };
  const double cheap = safe_amplitude(1e-8, "j1"), expensive = safe_amplitude(3.0, "j2");
  ASSERT_LT(cheap, expensive);
  const double target = 0.5 * (cheap + expensive);
  FakeControl control("j3");
  const json result = run("design-lq", {{"plant_model", plant}, {"max_input", target}}, control);
  expect_progress(control);
  const json& summary = result.at("summary");
  const double R = summary.at("R").get<double>();
  EXPECT_GT(R, 1e-8);
  EXPECT_LT(R, 3.0);
  EXPECT_GE(summary.at("max_input_noise").get<double>(), target);
  EXPECT_EQ(summary.at("R_search").at("target_noise_amplitude"), target);
  // A design 2 % cheaper misses the target: R is the smallest that meets it.
  EXPECT_LT(safe_amplitude(R / 1.02, "j4"), target);
  const models::LqFeedforward ff = models::lq_feedforward_from_json(*store_->model(result.at("model_id").get<std::string>()));
  EXPECT_EQ(ff.weights.R, R);
  EXPECT_EQ(ff.meta.at("R_search"), summary.at("R_search"));
}

TEST_F(JobKindsTest, DesignNnTrainsOnANarxPlantBehindTheLqController) {
  json params = design_nn_models();
  const std::string narx = params.at("plant_model");
  params.update({{"samples", 1000}, {"max_iterations", 3}, {"hidden", {3}}});
  FakeControl control("j3");
  const json result = run("design-nn", params, control);
  expect_progress(control);
  const std::string id = result.at("model_id").get<std::string>();
  ASSERT_TRUE(store_->find(id));
  EXPECT_EQ(store_->find(id)->kind, "neural_feedback");
  const models::NeuralFeedback fb = models::neural_feedback_from_json(*store_->model(id));
  EXPECT_EQ(fb.structure.hidden, std::vector<int>{3});
  EXPECT_EQ(fb.meta.at("plant"), narx);
  const json& history = result.at("plots").at("history");
  expect_plot(history, {"iteration", "j_est_pct", "j_val_pct"});
  EXPECT_LE(history.at("iteration").size(), 4u);
  EXPECT_LE(result.at("j_val_pct").get<double>(), result.at("summary").at("jc_val_before_pct").get<double>());
}

// A stored neural state-space plant model (identify ss; uploaded, validated as the API does) is a plant a
// design-nn job trains on: the controller it stores runs that ss model in its loop, and training lowers the
// validation J_c from the start.
TEST_F(JobKindsTest, DesignNnTrainsOnAStateSpacePlantModel) {
  json params = design_nn_models();
  const models::SsModel ss =
      testing_support::resonant_ss(100.0, kFs, 0.1, 0.0, 0.05, 0.0, 0.0, models::Scaling{}, 1, true);
  const json file = models::ss_model_to_json(ss);
  const ValidatedModel v = validate_model(file);
  ASSERT_EQ(v.kind, "ss");
  const std::string ss_id = store_->put(file, v.kind, v.fs, "resonance", "upload").id;
  params.update({{"plant_model", ss_id}, {"samples", 1000}, {"max_iterations", 5}, {"hidden", {3}}});
  const json result = run("design-nn", params, "j3");
  const std::string id = result.at("model_id").get<std::string>();
  ASSERT_TRUE(store_->find(id));
  const models::NeuralFeedback fb = models::neural_feedback_from_json(*store_->model(id));
  EXPECT_STREQ(fb.plant.kind(), "ss");
  EXPECT_EQ(fb.meta.at("plant"), ss_id);
  EXPECT_LT(result.at("j_val_pct").get<double>(), result.at("summary").at("jc_val_before_pct").get<double>());
  // A linear plant model is refused naming the key and the kinds it takes.
  params["plant_model"] = store_reference_model();
  const std::string message = refusal("design-nn", params);
  EXPECT_NE(message.find("plant_model"), std::string::npos) << message;
  EXPECT_NE(message.find("ss"), std::string::npos) << message;
}

TEST_F(JobKindsTest, DesignNnTakesTheControllersLagsAndTheRecordsShape) {
  json params = design_nn_models();
  params.update({{"samples", 1000}, {"max_iterations", 2}, {"hidden", {3}}, {"nu", 1}, {"nv", 3}, {"ny", 2},
                 {"sine_share", 0.5}, {"sine_peak", 0.4}, {"program_share", 0.25}, {"rail_penalty", 3.0}, {"dc_penalty", 0.5},
                 {"seed", 5}});
  FakeControl control("j3");
  const json result = run("design-nn", params, control);
  expect_progress(control);

  // The stored controller has the lags asked for: N1 takes u(k..k-1), v(k-1..k-3), y(k-1..k-2).
  const std::string id = result.at("model_id").get<std::string>();
  const models::NeuralFeedback fb = models::neural_feedback_from_json(*store_->model(id));
  EXPECT_EQ(fb.structure.nu, 1);
  EXPECT_EQ(fb.structure.nv, 3);
  EXPECT_EQ(fb.structure.ny, 2);
  EXPECT_EQ(fb.structure.inputs(), 7);
  // Summary and meta report what the design ran with (read back from the options it was given).
  const json& summary = result.at("summary");
  for (const json* reported : {&summary, &fb.meta}) {
    for (const char* key : {"samples", "max_iterations", "hidden", "nu", "nv", "ny", "sine_share", "sine_peak",
                            "program_share", "rail_penalty", "dc_penalty", "seed"}) {
      EXPECT_EQ(reported->at(key), params.at(key)) << key;
    }
    EXPECT_EQ(reported->at("restarts"), 1);
    EXPECT_EQ(reported->at("restart_jc_val_pct").size(), 1u);
  }
  EXPECT_EQ(summary.at("chosen_restart"), 0);
  EXPECT_EQ(fb.meta.at("restart"), 0);

  // The record's shape reaches the design: other sine shares make other records, so another J_c before training.
  params.update({{"sine_share", 0.0}, {"max_iterations", 0}});
  const json noise_only = run("design-nn", params, "j4");
  EXPECT_NE(noise_only.at("summary").at("jc_val_before_pct"), summary.at("jc_val_before_pct"));
}

// Tuned on a device (a preset, two playbacks) from a stored controller, with no iteration: the design is
// models::design_feedback's with that device and start (the same first J_c), the weights are the start's, and
// the meta names both; a start with restarts is refused.
TEST_F(JobKindsTest, DesignNnTunesOnADeviceFromAStoredController) {
  json params = design_nn_models();
  params.update({{"samples", 1000}, {"max_iterations", 1}, {"hidden", {3}}, {"desired", "plant-fundamental"}});
  const std::string start_id = run("design-nn", params, "j3").at("model_id");
  params.update({{"max_iterations", 0}, {"tune_on", "linear"}, {"tune_playbacks", 2}, {"start_from", start_id}});
  FakeControl control("j4");
  const json result = run("design-nn", params, control);
  expect_progress(control);
  const models::NeuralFeedback start = models::neural_feedback_from_json(*store_->model(start_id));
  const models::NeuralFeedback tuned =
      models::neural_feedback_from_json(*store_->model(result.at("model_id").get<std::string>()));
  EXPECT_EQ(tuned.net.parameters(), start.net.parameters());
  EXPECT_EQ(tuned.meta.at("tuned_on"), "linear");
  EXPECT_EQ(tuned.meta.at("start_from"), start_id);
  EXPECT_EQ(tuned.meta.at("device_playbacks"), 2);
  EXPECT_EQ(result.at("summary").at("device_playbacks"), 2);
  // the same design by the library: the first validation J_c is the device's, not the plant model's
  models::FeedbackDesignOptions o;
  o.samples = 1000;
  o.structure = start.structure;
  o.desired = models::DesiredResponse::plant_fundamental;
  o.training.max_iterations = 0;
  o.device_playbacks = 2;
  const models::PlantConfig device = models::plant_preset("linear");
  const models::NarxModel plant = models::narx_model_from_json(*store_->model(params.at("plant_model")));
  const models::LqFeedforward ff = models::lq_feedforward_from_json(*store_->model(params.at("feedforward_model")));
  const models::FeedbackDesign expected =
      models::design_feedback(plant, ff, dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs), o, &device, &start);
  EXPECT_DOUBLE_EQ(result.at("summary").at("jc_val_before_pct").get<double>(),
                   expected.training.history.front().jc_val_pct);
  const models::FeedbackDesign on_model =
      models::design_feedback(plant, ff, dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs), o, nullptr, &start);
  EXPECT_NE(result.at("summary").at("jc_val_before_pct").get<double>(), on_model.training.history.front().jc_val_pct);
  params.update({{"restarts", 2}});
  EXPECT_EQ(refusal("design-nn", params), "params.start_from: training on from a controller is one training, and restarts is 2");
}

// The evaluate job is `panelbass chain` + `evaluate`: its rows are evaluation::evaluate_chain's on a chain built
// here from the same stored models (the feedforward's band-pass from its design), and its attribution is
// evaluation::attribute_distortion's.

TEST_F(JobKindsTest, DesignNnKeepsTheBestOfItsRestarts) {
  json params = design_nn_models();
  params.update({{"samples", 1000}, {"max_iterations", 2}, {"hidden", {3}}, {"restarts", 2}});
  FakeControl control("j3");
  const json result = run("design-nn", params, control);
  expect_progress(control);
  bool named_second_restart = false;
  for (const Report& r : control.reports) named_second_restart = named_second_restart || r.message.starts_with("restart 2/2");
  EXPECT_TRUE(named_second_restart);

  const json& summary = result.at("summary");
  EXPECT_EQ(summary.at("restarts"), 2);
  const std::vector<double> scores = summary.at("restart_jc_val_pct").get<std::vector<double>>();
  ASSERT_EQ(scores.size(), 2u);
  EXPECT_NE(scores[0], scores[1]) << "restarts start from different weights";
  const int chosen = scores[1] < scores[0] ? 1 : 0;
  EXPECT_EQ(summary.at("chosen_restart"), chosen);
  EXPECT_DOUBLE_EQ(result.at("j_val_pct").get<double>(), scores[static_cast<std::size_t>(chosen)]);
  EXPECT_DOUBLE_EQ(summary.at("jc_val_after_pct").get<double>(), scores[static_cast<std::size_t>(chosen)]);
  const json meta = store_->model(result.at("model_id").get<std::string>())->at("meta");
  EXPECT_EQ(meta.at("restart"), chosen);
  EXPECT_EQ(meta.at("restart_jc_val_pct"), summary.at("restart_jc_val_pct"));
}

// The job passes the target, the weighting and the restart choice on as `design nn` takes them: kept by the
// worst probe, the restart kept is the one whose largest THD change over the probes is the most negative.
TEST_F(JobKindsTest, DesignNnCanKeepTheRestartThatCutsItsWorstProbeMost) {
  json params = design_nn_models();
  params.update({{"samples", 1000}, {"max_iterations", 2}, {"hidden", {3}}, {"restarts", 2}, {"desired", "plant-fundamental"},
                 {"weighting", "distortion"}, {"keep", "worst-probe"}, {"probes_hz", {80.0, 200.0}}});
  FakeControl control("j3");
  const json result = run("design-nn", params, control);
  const json& summary = result.at("summary");
  EXPECT_EQ(summary.at("desired"), "plant-fundamental");
  EXPECT_EQ(summary.at("distortion_weighting"), true);
  EXPECT_EQ(summary.at("level_weighting"), false);
  EXPECT_EQ(summary.at("keep"), "worst-probe");
  EXPECT_EQ(summary.at("probe_hz"), json({80.0, 200.0}));
  const json changes = summary.at("restart_probe_change_db");
  ASSERT_EQ(changes.size(), 2u);
  std::vector<double> worst;
  for (const json& c : changes) {
    ASSERT_EQ(c.size(), 2u);
    worst.push_back(std::max(c[0].get<double>(), c[1].get<double>()));
  }
  EXPECT_EQ(summary.at("chosen_restart"), worst[1] < worst[0] ? 1 : 0);
  const json meta = store_->model(result.at("model_id").get<std::string>())->at("meta");
  EXPECT_EQ(meta.at("restart_probe_change_db"), changes);
}

}  // namespace
}  // namespace panelbass::api::job_testing

// The evaluate, analyze and diagnose jobs: a chain evaluated on the virtual transducer, a model judged on a
// record, and a simulation's mismatch diagnosed.

#include <gtest/gtest.h>

#include "tests/api/jobs/job_test_fixture.h"
#include "usecases/analyze.h"

namespace panelbass::api::job_testing {
namespace {

// The chain an evaluate job builds from a stored LQ feedforward `ff_model`: its 20-1200 Hz band-pass (the design
// job's default) and the feedforward.
engine::ChainConfig band_pass_lq_chain(const json& ff_model) {
  engine::ChainConfig config;
  config.fs = kFs;
  config.band_pass.design = {engine::Hertz{20.0}, engine::Hertz{1200.0}, 2};
  config.feedforward = engine::SlotConfig{};
  config.feedforward->model = ff_model;
  return config;
}

TEST_F(JobKindsTest, EvaluateIsTheChainsEvaluationOnTheVirtualTransducer) {
  use_plant("panel-exciter");
  json models = design_nn_models();
  const json design = run("design-nn", {{"plant_model", models.at("plant_model")}, {"feedforward_model", models.at("feedforward_model")},
                                        {"samples", 1000}, {"max_iterations", 2}, {"hidden", {3}}},
                          "j3");
  const std::string ff = models.at("feedforward_model"), fb = design.at("model_id");
  const json params = {{"feedforward_model", ff}, {"feedback_model", fb}, {"probes_hz", {80.0, 160.0}},
                       {"probe_peak", 0.6}, {"noise_samples", 4096}, {"attribute", true}};
  FakeControl control("j4");
  const json result = run("evaluate", params, control);
  expect_progress(control);

  engine::ChainConfig config = band_pass_lq_chain(*store_->model(ff));
  config.feedback = engine::SlotConfig{};
  config.feedback->model = *store_->model(fb);
  evaluation::EvaluationOptions options;
  options.probe_hz = {80.0, 160.0};
  options.probe_peak = 0.6;
  options.noise_samples = 4096;
  const evaluation::ChainEvaluation expected = evaluation::evaluate_chain(config, *env_.plant, options);
  ASSERT_EQ(result.at("rows").size(), 3u);
  for (std::size_t r = 0; r < 3; ++r) {
    EXPECT_EQ(result.at("rows")[r], without_non_finite(evaluation::evaluation_row_to_json(expected.rows[r]))) << r;
  }
  const json& summary = result.at("summary");
  EXPECT_EQ(summary.at("plant"), env_.plant->name) << "the server's own transducer by default";
  EXPECT_EQ(summary.at("feedback_model"), fb);
  EXPECT_EQ(summary.at("source"), "model");
  EXPECT_EQ(summary.at("table").at("band-pass + feedforward + feedback").at("thd_pct")[1],
            expected.rows[2].probes[1].thd_pct);
  expect_plot(result.at("plots").at("response"), {"f", "plant_db", "feedforward_db", "feedback_db"});
  expect_plot(result.at("plots").at("thd"), {"f", "plant_thd_pct", "feedforward_thd_pct", "feedback_thd_pct"});

  const std::vector<evaluation::TermDistortion> terms = evaluation::attribute_distortion(config, *env_.plant, options);
  ASSERT_EQ(result.at("attribution").size(), terms.size());
  for (std::size_t t = 0; t < terms.size(); ++t) {
    EXPECT_EQ(result.at("attribution")[t].at("term"), terms[t].term);
    EXPECT_EQ(summary.at("attribution_thd_pct").at(terms[t].term)[1], terms[t].rows[1].probes[1].thd_pct) << terms[t].term;
  }

  // A preset instead, and band-pass + feedforward alone: two rows, no attribution unless asked for.
  const json alone = run("evaluate", {{"feedforward_model", ff}, {"plant", "linear"}, {"probes_hz", {160.0}},
                                      {"noise_samples", 4096}}, "j5");
  EXPECT_EQ(alone.at("rows").size(), 2u);
  EXPECT_EQ(alone.at("summary").at("plant"), "linear");
  EXPECT_EQ(alone.at("summary").at("feedback_model"), nullptr);
  EXPECT_FALSE(alone.contains("attribution"));
}

TEST_F(JobKindsTest, EvaluateRefusalsNameTheField) {
  const json models = design_nn_models();
  const std::string ff = models.at("feedforward_model"), narx = models.at("plant_model");
  const auto refused = [&](const json& extra) {
    json params = {{"feedforward_model", ff}};
    params.update(extra);
    return refusal("evaluate", params);
  };
  EXPECT_NE(refusal("evaluate", json::object()).find("params.feedforward_model"), std::string::npos);
  EXPECT_EQ(refused({{"feedback_model", narx}}),
            "params.feedback_model: model " + narx + " is of kind \"narx\", expected neural_feedback");
  EXPECT_EQ(refused({{"source", "sensor"}}),
            "params.source: \"sensor\" is where a feedback stage takes its past outputs from, and there is no feedback_model");
  // No virtual transducer behind this server: the presets only.
  EXPECT_EQ(refused({{"plant", "server"}}), "params.plant: must be one of \"panel-exciter\", \"linear\", got \"server\"");
  // the use case's words (usecases/evaluate.h), as `panelbass evaluate` says them
  EXPECT_EQ(refused({{"probes_hz", {40.0, 1500.0}}}), "params.probes_hz: each must be within (0, 1500) Hz, got 1500");
  EXPECT_EQ(refused({{"noise_samples", 100}}), "params.noise_samples: must be within 4096..100000000, got 100");
  EXPECT_EQ(refused({{"probe_peak", 1.5}}), "params.probe_peak: must be within [0, 1], got 1.5");
  EXPECT_EQ(refused({{"attribute", "yes"}}), "params.attribute: expected true or false, got \"yes\"");
  EXPECT_EQ(refused({{"speed", 1}}), "params.speed: unknown field");
  use_plant("linear");
  EXPECT_NO_THROW(validate_job_params("evaluate", {{"feedforward_model", ff}, {"plant", "server"}}, env_));
}


TEST_F(JobKindsTest, EvaluateLevelSweepIsTheLibrarysAndPlotsEachProbe) {
  use_plant("panel-exciter");
  const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}, {"r", 3.0}}, "j1").at("model_id");
  const json params = {{"feedforward_model", lq}, {"probes_hz", {80.0}}, {"noise_samples", 4096}, {"level_sweep", true}};
  FakeControl control("j2");
  const json result = run("evaluate", params, control);
  expect_progress(control);

  const engine::ChainConfig config = band_pass_lq_chain(*store_->model(lq));
  evaluation::LevelSweepOptions options;
  options.frequencies_hz = {80.0};
  const evaluation::LevelSweep expected = evaluation::sweep_levels(config, *env_.plant, options);
  EXPECT_EQ(result.at("level_sweep"), without_non_finite(evaluation::level_sweep_to_json(expected)));
  // the web UI's plot: equal-length columns, one entry per level the chain reached
  const json& plot = result.at("plots").at("thd_vs_level_80");
  std::size_t reached = 0;
  for (const evaluation::LevelPoint& p : expected.curves.at(0).points) reached += p.reachable ? 1 : 0;
  EXPECT_EQ(plot.at("level").size(), reached);
  EXPECT_EQ(plot.at("chain_thd_pct").size(), reached);
  EXPECT_EQ(plot.at("plant_thd_pct").size(), reached);
}

TEST_F(JobKindsTest, AnalyzeJudgesAModelOnARecord) {
  const std::string model = store_reference_model();
  run("excite", {{"samples", 3000}, {"validation_samples", 2000}}, "j1");
  FakeControl control("j2");
  const json result = run("analyze", {{"model", model}, {"record", "j1"}}, control);
  expect_progress(control);
  EXPECT_FALSE(result.contains("model_id"));
  // The reference model is the system itself: J is the noise's share, tiny.
  EXPECT_LT(result.at("j_val_pct").get<double>(), 0.01);
  EXPECT_LT(result.at("j_est_pct").get<double>(), 0.01);
  EXPECT_EQ(result.at("summary").at("kind"), "linear");
  EXPECT_EQ(result.at("summary").at("model"), model);
  expect_plot(result.at("plots").at("fit"), {"t", "measured", "simulated"});
  expect_plot(result.at("plots").at("spectrum"), {"f", "measured_db", "model_db"});
  expect_plot(result.at("plots").at("history"), {"iteration", "j_est_pct", "j_val_pct"}, {"j_val_pct"});
}

TEST_F(JobKindsTest, DiagnoseAgainstAGivenBaseline) {
  const std::string baseline = store_reference_model();
  FakeControl control("j4");
  const json result =
      run("diagnose", {{"excite", {{"samples", 3000}, {"validation_samples", 2000}}}, {"baseline_model", baseline}, {"max_findings", 1}},
          control);
  expect_progress(control);
  EXPECT_TRUE(result.contains("findings"));
  EXPECT_LT(result.at("J_val_before_pct").get<double>(), 0.01);
  EXPECT_LE(result.at("J_val_after_pct").get<double>(), result.at("J_val_before_pct").get<double>());
  expect_plot(result.at("plots").at("fit"), {"t", "measured", "simulated"});
  expect_plot(result.at("plots").at("residual_spectrum"), {"frequency_hz", "before_db", "after_db", "noise_floor_db"});
}

TEST_F(JobKindsTest, AnalyzeANarxModelShowsHarmonicsOfPlantAndModel) {
  use_plant("panel-exciter");
  run("excite", {{"samples", 3000}, {"validation_samples", 1000}, {"amplitude", 0.8}}, "j1");
  const std::string narx =
      run("identify-narx", {{"record", "j1"}, {"na", 4}, {"nb", 4}, {"hidden", {4}}, {"max_iterations", 3}}, "j2").at("model_id");
  FakeControl control("j3");
  const json result = run("analyze", {{"model", narx}, {"record", "j1"}}, control);
  expect_progress(control);
  EXPECT_EQ(result.at("summary").at("kind"), "narx");
  const json& plots = result.at("plots");
  expect_plot(plots.at("fit"), {"t", "measured", "simulated"});
  expect_plot(plots.at("spectrum"), {"f", "measured_db", "model_db"});
  // The training history comes from the model file's meta.
  expect_plot(plots.at("history"), {"iteration", "j_est_pct", "j_val_pct"});
  // analyze's stepped sines (usecases::AnalyzeRequest: 40-640 Hz): the H3 of 640 Hz lies above 1500 Hz, so null
  expect_plot(plots.at("harmonics"), {"f", "measured_h2_db", "measured_h3_db", "model_h2_db", "model_h3_db"},
              {"measured_h3_db", "model_h3_db"});
  EXPECT_EQ(plots.at("harmonics").at("f").size(), usecases::AnalyzeRequest{}.frequencies.size());
}

TEST_F(JobKindsTest, DiagnoseFindsItsOwnBaselineOnTheVirtualTransducer) {
  use_plant("panel-exciter");
  FakeControl control("j1");
  const json result =
      run("diagnose", {{"excite", {{"samples", 3000}, {"validation_samples", 2000}, {"amplitude", 0.8}}}, {"max_findings", 1}}, control);
  expect_progress(control);
  EXPECT_EQ(result.at("baseline").at("source"), "identified");
  EXPECT_LE(result.at("J_val_after_pct").get<double>(), result.at("J_val_before_pct").get<double>());
  expect_plot(result.at("plots").at("fit"), {"t", "measured", "simulated"});
  // The residual spectra before and after: the residual's power (Σ of the PSD bins) falls with J.
  const json& spectrum = result.at("plots").at("residual_spectrum");
  expect_plot(spectrum, {"frequency_hz", "before_db", "after_db", "noise_floor_db"});
  double before = 0.0, after = 0.0;
  for (std::size_t k = 0; k < spectrum.at("frequency_hz").size(); ++k) {
    EXPECT_GT(spectrum.at("frequency_hz")[k].get<double>(), 0.0) << "DC is left out";
    before += std::pow(10.0, spectrum.at("before_db")[k].get<double>() / 10.0);
    after += std::pow(10.0, spectrum.at("after_db")[k].get<double>() / 10.0);
  }
  EXPECT_LE(after, 1.01 * before);
  // The noise floor is one level, below the residual before the diagnosis.
  const double floor_db = spectrum.at("noise_floor_db")[0].get<double>();
  for (const json& v : spectrum.at("noise_floor_db")) EXPECT_EQ(v.get<double>(), floor_db);
  EXPECT_LT(std::pow(10.0, floor_db / 10.0) * static_cast<double>(spectrum.at("frequency_hz").size()), before);
}

TEST_F(JobKindsTest, DiagnoseANarxBaselineStartsFromTheJTheAnalyzeJobGivesIt) {
  use_plant("panel-exciter");
  run("excite", {{"samples", 3000}, {"validation_samples", 2000}, {"amplitude", 0.8}}, "j1");
  const std::string narx =
      run("identify-narx", {{"record", "j1"}, {"na", 2}, {"nb", 3}, {"hidden", {3}}, {"max_iterations", 3}}, "j2").at("model_id");
  const double j_analyzed = run("analyze", {{"model", narx}, {"record", "j1"}}, "j3").at("j_val_pct").get<double>();
  FakeControl control("j4");
  const json result = run("diagnose", {{"record", "j1"}, {"baseline_model", narx}, {"max_findings", 1}}, control);
  expect_progress(control);
  EXPECT_EQ(result.at("baseline").at("kind"), "narx");
  EXPECT_NEAR(result.at("J_val_before_pct").get<double>(), j_analyzed, 1e-6 * j_analyzed);
  EXPECT_LE(result.at("J_val_after_pct").get<double>(), result.at("J_val_before_pct").get<double>());
  expect_plot(result.at("plots").at("residual_spectrum"), {"frequency_hz", "before_db", "after_db", "noise_floor_db"});
}

// The diagnosed model is stored (kind gray_box, as diagnose --model-out writes it), and a diagnosis takes it as its
// baseline: on the same record its J before is the first diagnosis's J after (the same simulation, the same init).
TEST_F(JobKindsTest, DiagnoseStoresAGrayBoxModelThatADiagnosisTakesAsItsBaseline) {
  use_plant("panel-exciter");
  run("excite", {{"samples", 3000}, {"validation_samples", 2000}, {"amplitude", 0.8}}, "j1");
  const json first = run("diagnose", {{"record", "j1"}, {"max_findings", 1}}, "j2");
  ASSERT_FALSE(first.at("findings").empty()) << first.dump(1);
  ASSERT_TRUE(first.contains("model_id")) << first.dump(1);
  FakeControl control("j3");
  const json second =
      run("diagnose", {{"record", "j1"}, {"baseline_model", first.at("model_id")}, {"max_findings", 1}}, control);
  expect_progress(control);
  EXPECT_EQ(second.at("baseline").at("kind"), "gray_box");
  const double j_after = first.at("J_val_after_pct").get<double>();
  EXPECT_NEAR(second.at("J_val_before_pct").get<double>(), j_after, 1e-6 * j_after);
  EXPECT_LE(second.at("J_val_after_pct").get<double>(), second.at("J_val_before_pct").get<double>());
}

// Records at several levels ("records"): the loudest is diagnosed, the other's validation part judges each finding,
// and the result lists both; "records" beside "record" is refused, naming the field.
TEST_F(JobKindsTest, DiagnoseTakesRecordsAtSeveralLevels) {
  use_plant("panel-exciter");
  run("excite", {{"samples", 3000}, {"validation_samples", 2000}, {"amplitude", 0.3}}, "j1");
  run("excite", {{"samples", 3000}, {"validation_samples", 2000}, {"amplitude", 0.8}}, "j2");
  const json result = run("diagnose", {{"records", {"j1", "j2"}}, {"max_findings", 1}}, "j3");
  ASSERT_TRUE(result.contains("levels")) << result.at("data") << " " << result.at("stopped").dump();
  ASSERT_EQ(result.at("levels").size(), 2u) << result.dump(1);
  EXPECT_FALSE(result.at("levels")[0].at("diagnosed").get<bool>());
  EXPECT_TRUE(result.at("levels")[1].at("diagnosed").get<bool>());
  EXPECT_EQ(result.at("data"), "job j2");
  for (const json& f : result.at("findings"))
    EXPECT_EQ(f.at("evidence").at("levels").at("records").size(), 2u) << f.dump(1);
  for (const json& bad : {json{{"records", {"j1"}}, {"record", "j1"}}, json{{"records", json::array()}}, json{{"records", {"j9"}}}}) {
    try {
      validate_job_params("diagnose", bad, env_);
      ADD_FAILURE() << bad.dump();
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("params.records"), std::string::npos) << e.what();
    }
  }
}

TEST_F(JobKindsTest, DiagnoseRefusesABaselineThatIsNotASimulation) {
  const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}, {"r", 3.0}}, "j1").at("model_id");
  try {
    validate_job_params("diagnose", {{"baseline_model", lq}}, env_);
    FAIL() << "an LQ feedforward is not a simulation of the plant";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("baseline_model"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace panelbass::api::job_testing

// The job kinds of ROUTES.md "Jobs": the registry, params validation (named fields, defaults) across the
// kinds, and what every kind's work shares (seeded excitations, null validation figures, a failing backend).

#include <gtest/gtest.h>

#include "models/control/lq_feedforward.h"
#include "tests/api/jobs/job_test_fixture.h"

namespace panelbass::api::job_testing {
namespace {

// ----- validation ------------------------------------------------------------------------------------

TEST(JobKinds, ListsTheKindsInTheOrderOfRoutes) {
  EXPECT_EQ(job_kinds(), (std::vector<std::string>{"excite", "identify-linear", "identify-narx", "identify-oscillator",
                                                   "identify-ss", "identify-average", "identify-mimo", "validate", "design-lq",
                                                   "design-nn", "design-mirror", "evaluate", "analyze", "harmonics", "diagnose", "verify", "tune", "plant-survey"}));
}

TEST_F(JobKindsTest, UnknownKindIsRefusedWithTheKindsThereAre) {
  const std::string message = refusal("fly", json::object());
  EXPECT_NE(message.find("kind: unknown job kind \"fly\"; expected one of excite, identify-linear"), std::string::npos) << message;
  EXPECT_THROW(job_work("fly", env_), std::invalid_argument);
}

TEST_F(JobKindsTest, UnknownFieldIsNamedAtItsPath) {
  EXPECT_EQ(refusal("excite", {{"samples", 3000}, {"foo", 1}}), "params.foo: unknown field");
  EXPECT_EQ(refusal("identify-linear", {{"excite", {{"bar", true}}}}), "params.excite.bar: unknown field");
  EXPECT_EQ(refusal("design-lq", {{"plant_model", store_reference_model()}, {"band_pass", {{"q", 1}}}}),
            "params.band_pass.q: unknown field");
}

TEST_F(JobKindsTest, WrongTypesAndRangesAreNamed) {
  EXPECT_EQ(refusal("excite", {{"samples", "many"}}), "params.samples: must be an integer in [200, 10000000], got \"many\"");
  EXPECT_EQ(refusal("excite", {{"samples", 100}}), "params.samples: must be an integer in [200, 10000000], got 100");
  EXPECT_EQ(refusal("excite", {{"amplitude", 1.5}}), "params.amplitude: must be a number in (0, 1], got 1.5");
  EXPECT_EQ(refusal("excite", {{"amplitude", 0}}), "params.amplitude: must be a number in (0, 1], got 0");
  EXPECT_NE(refusal("excite", {{"signal", "chirp"}}).find("params.signal: must be one of \"noise\", \"multisine\""), std::string::npos);
  EXPECT_NE(refusal("excite", {{"validation_samples", 50}}).find("params.validation_samples"), std::string::npos);
  EXPECT_NE(refusal("identify-linear", {{"order", 201}}).find("params.order: must be within 1..200, got 201"), std::string::npos);
  EXPECT_NE(refusal("identify-linear", {{"order", 2.5}}).find("params.order"), std::string::npos);
  EXPECT_NE(refusal("identify-linear", {{"scan", {5, 2}}}).find("params.scan"), std::string::npos);
  EXPECT_NE(refusal("identify-linear", {{"scan", {2, 6}}, {"excite", {{"validation_samples", 0}}}}).find("params.scan: an order scan needs validation data"),
            std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"hidden", json::array()}}).find("params.hidden"), std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"hidden", {8, 0}}}).find("params.hidden: must be within 1..10000, got 0"), std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"modes", {"pem", "gradient"}}}).find("params.modes: must be pem, oem-s, oem-d, oem-n or oem-ms, got \"gradient\""), std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"pem_min_progress", 1.0}}).find("params.pem_min_progress"), std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"friction_units", {3.0, -1.0}}}).find("params.friction_units: each gain must be within (0, 1000], got -1"), std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"friction_units", {3.0, 10.0}}, {"friction_lags", 5}, {"hidden", {8}}})
                .find("params.friction_units: 2 gains x 5 lags"),
            std::string::npos);
  EXPECT_EQ(refusal("excite", json::array()), "params: expected an object, got array");
  EXPECT_NE(refusal("diagnose", {{"excite", {{"validation_samples", 0}}}}).find("params.excite.validation_samples"), std::string::npos);
}

TEST_F(JobKindsTest, DefaultsAreFilledIn) {
  const json excite = validate_job_params("excite", json::object(), env_);
  EXPECT_EQ(excite, (json{{"signal", "noise"}, {"samples", 10000}, {"validation_samples", 5000}, {"amplitude", 0.3}, {"seed", 1}}));
  // An integral float such as 1e4 is an integer.
  EXPECT_EQ(validate_job_params("excite", {{"samples", 1e4}}, env_).at("samples"), 10000);

  const json linear = validate_job_params("identify-linear", nullptr, env_);
  EXPECT_EQ(linear.at("excite"), excite);
  EXPECT_FALSE(linear.contains("record"));
  EXPECT_EQ(linear.at("method"), "oe");
  EXPECT_EQ(linear.at("order"), 8);
  EXPECT_EQ(linear.at("delay"), -1);
  EXPECT_TRUE(linear.at("scan").is_null());
  EXPECT_EQ(linear.at("max_iterations"), 100);

  const json narx = validate_job_params("identify-narx", json::object(), env_);
  // identify narx's documented recipe (docs/identification.md), as the CLI's defaults
  EXPECT_EQ(narx.at("hidden"), json({17}));
  EXPECT_EQ(narx.at("modes"), json({"pem", "oem-d"}));
  EXPECT_EQ(narx.at("na"), 8);
  EXPECT_EQ(narx.at("nb"), 8);
  EXPECT_EQ(narx.at("nk"), 0);
  EXPECT_EQ(narx.at("max_iterations"), 100);
  EXPECT_EQ(narx.at("friction_units"), json::array());
  EXPECT_EQ(narx.at("friction_lags"), 1);
  EXPECT_EQ(narx.at("weighted"), false);

  // design-lq's defaults are the request's, as `design lq` has them: the weights of models::LqWeights (r unset: the
  // use case takes LqWeights's R), the band 20-1200 Hz of order 2, 100 000 noise samples.
  const json lq = validate_job_params("design-lq", {{"plant_model", store_reference_model()}}, env_);
  EXPECT_TRUE(lq.at("r").is_null());
  EXPECT_TRUE(lq.at("max_input").is_null());
  EXPECT_EQ(lq.at("r0"), models::LqWeights{}.R0);
  EXPECT_EQ(lq.at("band_pass"), (json{{"low_hz", 20.0}, {"high_hz", 1200.0}, {"order", 2}}));
  EXPECT_EQ(lq.at("noise_samples"), 100000);
}

TEST_F(JobKindsTest, DesignNnDefaultsComeFromTheDesignOptions) {
  const json models = design_nn_models();
  const json nn = validate_job_params("design-nn", models, env_);
  const models::FeedbackDesignOptions design;
  EXPECT_EQ(nn.at("nu"), design.structure.nu);
  EXPECT_EQ(nn.at("nv"), design.structure.nv);
  EXPECT_EQ(nn.at("ny"), design.structure.ny);
  EXPECT_EQ(nn.at("sine_share"), design.sine_share);
  EXPECT_EQ(nn.at("sine_peak"), design.sine_peak);
  EXPECT_EQ(nn.at("program_share"), design.program_share);
  EXPECT_EQ(nn.at("restarts"), 1);
  EXPECT_EQ(nn.at("desired"), "linear-model");
  EXPECT_EQ(nn.at("weighting"), "none");
  EXPECT_EQ(nn.at("keep"), "validation-jc");
  EXPECT_EQ(nn.at("probes_hz"), json({40.0, 80.0, 160.0, 320.0}));
  EXPECT_EQ(nn.at("rail_penalty"), design.training.rail_penalty);
  EXPECT_EQ(nn.at("dc_penalty"), design.training.dc_penalty);
  EXPECT_EQ(nn.at("samples"), design.samples);  // the request's (usecases/design_nn.h), as `design nn` has them
  EXPECT_EQ(nn.at("max_iterations"), design.training.max_iterations);
  EXPECT_EQ(nn.at("hidden"), json(design.structure.hidden));
  EXPECT_EQ(nn.at("sine_band"), json({design.sine_low_hz, design.sine_high_hz}));
  EXPECT_EQ(nn.at("band_pass"), nullptr);
  EXPECT_EQ(nn.at("tune_on"), "none");
  EXPECT_EQ(nn.at("tune_playbacks"), design.device_playbacks);
  EXPECT_EQ(nn.at("start_from"), nullptr);
}

TEST_F(JobKindsTest, DesignNnRangesAreNamed) {
  const json models = design_nn_models();
  const auto with = [&](const json& extra) {
    json params = models;
    params.update(extra);
    return params;
  };
  const auto refused = [&](const json& extra) { return refusal("design-nn", with(extra)); };
  EXPECT_EQ(refused({{"nu", 101}}), "params.nu: must be an integer in [0, 100], got 101");
  EXPECT_EQ(refused({{"nv", -1}}), "params.nv: must be an integer in [0, 100], got -1");
  EXPECT_EQ(refused({{"ny", 2.5}}), "params.ny: must be an integer in [0, 100], got 2.5");
  EXPECT_EQ(refused({{"sine_share", 1.5}}), "params.sine_share: must be a number in [0, 1], got 1.5");
  EXPECT_EQ(refused({{"sine_peak", 0}}), "params.sine_peak: must be a number in (0, 1], got 0");
  EXPECT_EQ(refused({{"program_share", -0.1}}), "params.program_share: must be a number in [0, 1], got -0.1");
  EXPECT_EQ(refused({{"restarts", 0}}), "params.restarts: must be an integer in [1, 20], got 0");
  EXPECT_EQ(refused({{"restarts", 21}}), "params.restarts: must be an integer in [1, 20], got 21");
  EXPECT_EQ(refused({{"rail_penalty", -1}}), "params.rail_penalty: must be a number in [0, 1e+12], got -1");
  EXPECT_EQ(refused({{"rail_penalty", "high"}}), "params.rail_penalty: must be a number in [0, 1e+12], got \"high\"");
  EXPECT_EQ(refused({{"dc_penalty", -0.5}}), "params.dc_penalty: must be a number in [0, 1e+12], got -0.5");
  EXPECT_EQ(refused({{"restart", 2}}), "params.restart: unknown field");
  EXPECT_EQ(refused({{"keep", "best"}}).rfind("params.keep: ", 0), 0u);
  EXPECT_EQ(refused({{"desired", "flat"}}).rfind("params.desired: ", 0), 0u);
  EXPECT_EQ(refused({{"weighting", "both"}}).rfind("params.weighting: ", 0), 0u);
  EXPECT_EQ(refused({{"probes_hz", json::array()}}).rfind("params.probes_hz: ", 0), 0u);
  EXPECT_EQ(refused({{"tune_on", "table"}}).rfind("params.tune_on: ", 0), 0u);
  EXPECT_EQ(refused({{"tune_playbacks", 2}}),
            "params.tune_playbacks: plays each drive into the device of tune_on, and tune_on is \"none\"");
  EXPECT_EQ(refused({{"tune_playbacks", 65}}), "params.tune_playbacks: must be an integer in [1, 64], got 65");
  EXPECT_EQ(refused({{"tune_on", "linear"}}).rfind("params.tune_on: tuning on the device", 0), 0u) << "the target";
  EXPECT_EQ(refused({{"tune_on", "linear"}, {"desired", "plant-fundamental"}, {"weighting", "level"}})
                .rfind("params.tune_on: tuning on the device", 0),
            0u);
  const std::string narx = models.at("plant_model");
  EXPECT_EQ(refused({{"start_from", narx}}),
            "params.start_from: model " + narx + " is of kind \"narx\", expected neural_feedback");
  // The ends that belong to the ranges.
  const json ends = with({{"nu", 0}, {"nv", 100}, {"sine_share", 0}, {"sine_peak", 1}, {"program_share", 1}, {"restarts", 20},
                          {"rail_penalty", 0}, {"dc_penalty", 0}});
  EXPECT_NO_THROW(validate_job_params("design-nn", ends, env_));
}

TEST_F(JobKindsTest, ReferencedModelsMustExistWithTheRightKind) {
  EXPECT_EQ(refusal("design-lq", json::object()), "params.plant_model: required");
  EXPECT_EQ(refusal("design-lq", {{"plant_model", store_reference_model()}, {"r", 1.0}, {"max_input", 0.3}}),
            "params.max_input: choose the weight by r or by max_input, not both");
  for (const double bad : {0.0, 1.5}) {
    EXPECT_NE(refusal("design-lq", {{"plant_model", store_reference_model()}, {"max_input", bad}}).find("params.max_input"),
              std::string::npos)
        << bad;
  }
  EXPECT_EQ(refusal("design-lq", {{"plant_model", "m000000000000"}}), "params.plant_model: no stored model \"m000000000000\"");
  EXPECT_NE(refusal("design-lq", {{"plant_model", "../etc"}}).find("params.plant_model: must be an id"), std::string::npos);
  const std::string linear = store_reference_model();
  EXPECT_EQ(refusal("design-nn", {{"plant_model", linear}, {"feedforward_model", linear}}),
            "params.plant_model: model " + linear + " is of kind \"linear\", expected narx or ss");
  EXPECT_EQ(refusal("analyze", json::object()), "params.model: required");
  EXPECT_NO_THROW(validate_job_params("diagnose", {{"baseline_model", linear}}, env_));
  EXPECT_NE(refusal("design-lq", {{"plant_model", linear}, {"band_pass", {{"high_hz", 1600}}}}).find("params.band_pass.high_hz"),
            std::string::npos);
}

TEST_F(JobKindsTest, RecordMustNameAFinishedExciteJob) {
  EXPECT_EQ(refusal("identify-linear", {{"record", "j99"}}),
            "params.record: no succeeded job \"j99\" (the record must name a finished excite job \"j…\" or an uploaded "
            "record \"r…\")");
  results_["j2"] = {{"model_id", "m0123456789ab"}};
  EXPECT_EQ(refusal("analyze", {{"model", store_reference_model()}, {"record", "j2"}}),
            "params.record: job j2 is not an excite job (its result has no \"record\")");
  results_["j3"] = {{"fs", kFs}, {"record", {{"u_est", {1.0, 2.0}}, {"y_est", {1.0}}, {"u_val", json::array()}, {"y_val", json::array()}}}};
  EXPECT_EQ(refusal("identify-narx", {{"record", "j3"}}),
            "params.record: job j3 has a record whose drive and response differ in length");
  EXPECT_EQ(refusal("identify-linear", {{"record", "j99"}, {"excite", json::object()}}),
            "params.record: give either \"record\" or \"excite\", not both");
  EXPECT_NE(refusal("identify-linear", {{"record", 3}}).find("params.record: expected the id of a finished excite job"), std::string::npos);
}


TEST_F(JobKindsTest, TheSameSeedRecordsTheSameExcitation) {
  const json a = run("excite", {{"samples", 500}, {"validation_samples", 300}, {"seed", 9}}, "j1");
  excitations_ = 0;  // the fake backend's noise is seeded by its call count
  const json b = run("excite", {{"samples", 500}, {"validation_samples", 300}, {"seed", 9}}, "j2");
  EXPECT_EQ(a.at("record"), b.at("record"));
  const json c = run("excite", {{"samples", 500}, {"validation_samples", 300}, {"seed", 10}}, "j3");
  EXPECT_NE(a.at("record").at("u_est"), c.at("record").at("u_est"));
}

TEST_F(JobKindsTest, WithoutValidationDataTheValidationFiguresAreNull) {
  const json result =
      run("identify-linear", {{"excite", {{"samples", 2000}, {"validation_samples", 0}}}, {"method", "arx"}, {"order", 2}}, "j1");
  EXPECT_TRUE(result.at("j_val_pct").is_null());
  EXPECT_LT(result.at("j_est_pct").get<double>(), 0.01);
  // ARX has no iterations: the history is the final model's one point.
  const json& history = result.at("plots").at("history");
  expect_plot(history, {"iteration", "j_est_pct", "j_val_pct"}, {"j_val_pct"});
  EXPECT_EQ(history.at("iteration").size(), 1u);
  EXPECT_TRUE(history.at("j_val_pct")[0].is_null());
  // The fit is shown on the estimation part.
  EXPECT_EQ(result.at("plots").at("fit").at("t").size(), 1950u);
  EXPECT_EQ(store_->model(result.at("model_id").get<std::string>())->at("meta").at("J_val_pct"), nullptr);
}

TEST_F(JobKindsTest, ABackendThatRecordsTooLittleFailsTheJob) {
  env_.excite = [](const Eigen::VectorXd& drive) { return Eigen::VectorXd(drive.head(drive.size() - 1)); };
  FakeControl control("j1");
  const json params = validate_job_params("excite", {{"samples", 300}}, env_);
  const std::string message =
      testing_support::message_of<std::runtime_error>([&] { job_work("excite", env_)(params, control); });
  EXPECT_EQ(message, "the backend recorded 299 samples for a drive of 300");
}

}  // namespace
}  // namespace panelbass::api::job_testing

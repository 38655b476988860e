// The identify-linear and identify-narx jobs: the reference system recovered, order scans, cancellation
// inside a fit, NARX training on the virtual transducer (friction seeds, harmonic weights).

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>

#include "api/jobs/model_judgement.h"
#include "tests/api/jobs/job_test_fixture.h"

namespace panelbass::api::job_testing {
namespace {

TEST_F(JobKindsTest, IdentifyLinearRecoversTheReferenceSystem) {
  run("excite", {{"samples", 3000}, {"validation_samples", 1000}, {"amplitude", 0.5}}, "j1");
  FakeControl control("j2");
  const json result = run("identify-linear", {{"record", "j1"}, {"method", "oe"}, {"order", 2}, {"max_iterations", 30}}, control);
  expect_progress(control);
  EXPECT_EQ(excitations_, 2) << "a record of its own was made although one was named";
  // The noise (σ = 1e-4 against an output rms near 0.5) leaves J far below 0.01 %.
  EXPECT_LT(result.at("j_est_pct").get<double>(), 0.01);
  EXPECT_LT(result.at("j_val_pct").get<double>(), 0.01);

  const std::string id = result.at("model_id").get<std::string>();
  const std::optional<StoredModel> stored = store_->find(id);
  ASSERT_TRUE(stored);
  EXPECT_EQ(stored->kind, "linear");
  EXPECT_EQ(stored->source, "j2");
  EXPECT_EQ(stored->name, "oe order 2 (j2)");
  const models::LinearModel model = models::linear_model_from_json(*store_->model(id));
  EXPECT_EQ(model.tf.nk, 1);
  // Poles: r·e^{±jθ} (scaling does not move poles); response in raw units at a few frequencies.
  const Eigen::VectorXcd poles = model.tf.poles();
  ASSERT_EQ(poles.size(), 2);
  for (Eigen::Index k = 0; k < 2; ++k) {
    EXPECT_NEAR(std::abs(poles[k]), kRadius, 1e-3);
    EXPECT_NEAR(std::abs(std::arg(poles[k])), 2.0 * std::numbers::pi * kResonanceHz / kFs, 1e-3);
  }
  for (double f : {50.0, 300.0, 900.0}) {
    const std::complex<double> h = model.tf.response(f, kFs) * model.scaling.y_scale / model.scaling.u_scale;
    const std::complex<double> truth = reference_system().response(f, kFs);
    EXPECT_LT(std::abs(h - truth) / std::abs(truth), 1e-2) << f << " Hz";
  }
  EXPECT_EQ(model.meta.at("J_est_pct"), result.at("j_est_pct"));

  const json& plots = result.at("plots");
  expect_plot(plots.at("fit"), {"t", "measured", "simulated"});
  EXPECT_EQ(plots.at("fit").at("t").size(), 950u);  // the validation part after the 50 initial samples
  expect_plot(plots.at("spectrum"), {"f", "measured_db", "model_db"});
  expect_plot(plots.at("history"), {"iteration", "j_est_pct", "j_val_pct"}, {"j_val_pct"});
  EXPECT_FALSE(plots.contains("harmonics")) << "a linear model has no harmonics";
  // The measured and the model's response agree at the resonance.
  const json& s = plots.at("spectrum");
  for (std::size_t k = 0; k < s.at("f").size(); ++k) {
    if (std::abs(s.at("f")[k].get<double>() - kResonanceHz) < 15.0) {
      EXPECT_NEAR(s.at("measured_db")[k].get<double>(), s.at("model_db")[k].get<double>(), 0.5);
    }
  }
  EXPECT_EQ(result.at("summary").at("order"), 2);
  // The reference system's one sample of delay, found in its impulse response and said so; a good fit warns of nothing.
  EXPECT_EQ(result.at("summary").at("delay"), 1);
  EXPECT_EQ(result.at("summary").at("nk_source").get<std::string>().rfind(
                "estimated from the impulse response's first significant tap (lag 1", 0),
            0u)
      << result.at("summary").at("nk_source");
  EXPECT_EQ(result.at("warnings"), json::array());
}

TEST_F(JobKindsTest, IdentifyLinearMakesItsOwnExcitationAndScansOrders) {
  FakeControl control("j5");
  const json result = run("identify-linear",
                          {{"excite", {{"samples", 2000}, {"validation_samples", 1000}}}, {"scan", {1, 4}}, {"max_iterations", 20}},
                          control);
  expect_progress(control);
  EXPECT_EQ(excitations_, 2);
  EXPECT_EQ(result.at("summary").at("scan").size(), 4u);
  // The smallest order within 5 % of the best validation J is the true one.
  EXPECT_EQ(result.at("summary").at("order"), 2);
  EXPECT_TRUE(store_->find(result.at("model_id").get<std::string>()));
}

TEST_F(JobKindsTest, CancellationInsideTheFitUnwindsTheJob) {
  run("excite", {{"samples", 3000}, {"validation_samples", 1000}}, "j1");
  FakeControl control("j2", 4);
  const json params = validate_job_params("identify-linear", {{"record", "j1"}, {"order", 4}}, env_);
  EXPECT_THROW(job_work("identify-linear", env_)(params, control), JobCancelled);
  EXPECT_TRUE(control.cancelled());
  EXPECT_EQ(control.reports.size(), 4u);
  EXPECT_TRUE(store_->list().empty()) << "a cancelled job stored a model";
}

TEST_F(JobKindsTest, CancellationDuringNarxTraining) {
  FakeControl control("j2", 6);
  const json params = validate_job_params(
      "identify-narx", {{"excite", {{"samples", 1000}, {"validation_samples", 500}}}, {"hidden", {3}}, {"max_iterations", 50}}, env_);
  EXPECT_THROW(job_work("identify-narx", env_)(params, control), JobCancelled);
  EXPECT_TRUE(store_->list().empty());
}

TEST_F(JobKindsTest, IdentifyNarxOnTheVirtualTransducer) {
  use_plant("panel-exciter");
  run("excite", {{"samples", 3000}, {"validation_samples", 1000}, {"amplitude", 0.8}}, "j1");
  FakeControl control("j2");
  const json result = run("identify-narx",
                          {{"record", "j1"}, {"na", 4}, {"nb", 4}, {"nk", -1}, {"hidden", {4}}, {"modes", {"pem", "oem-d"}},
                           {"max_iterations", 4}},
                          control);
  expect_progress(control);
  bool named_iteration = false;
  for (const Report& r : control.reports) named_iteration = named_iteration || r.message == "oem-d iteration 5";
  EXPECT_TRUE(named_iteration);

  const std::string id = result.at("model_id").get<std::string>();
  ASSERT_TRUE(store_->find(id));
  EXPECT_EQ(store_->find(id)->kind, "narx");
  const models::AnyModel model = models::model_from_json(*store_->model(id));
  EXPECT_EQ(model.kind(), "narx");
  EXPECT_DOUBLE_EQ(model.fs(), kFs);
  // The panel exciter's sensor noise alone leaves a few percent; a short training stays well below 100 %.
  EXPECT_LT(result.at("j_val_pct").get<double>(), 60.0);
  const json& plots = result.at("plots");
  expect_plot(plots.at("fit"), {"t", "measured", "simulated"});
  expect_plot(plots.at("spectrum"), {"f", "measured_db", "model_db"});
  expect_plot(plots.at("history"), {"iteration", "j_est_pct", "j_val_pct"});
  EXPECT_EQ(plots.at("history").at("iteration").size(), std::size_t{result.at("summary").at("iterations").get<std::size_t>() + 1});
  ASSERT_TRUE(plots.contains("harmonics"));
  expect_plot(plots.at("harmonics"), {"f", "measured_h2_db", "measured_h3_db", "model_h2_db", "model_h3_db"});
  EXPECT_EQ(plots.at("harmonics").at("f").size(), 4u);
  // The model kept is the one training selected on the J the job reports: the best validation J of the
  // history, computed with the same measured outputs setting the state (the history on the scaled record,
  // whose offset is removed, the report on the raw one: equal to a few parts in 10⁶, where a J from rest
  // would differ by the initial transient).
  double best_j_val = std::numeric_limits<double>::infinity();
  for (const json& v : plots.at("history").at("j_val_pct"))
    if (v.is_number()) best_j_val = std::min(best_j_val, v.get<double>());
  EXPECT_NEAR(result.at("j_val_pct").get<double>(), best_j_val, 1e-4 * best_j_val) << plots.at("history").dump();
  // The history is in the model file too, where analyze finds it.
  EXPECT_EQ(store_->model(id)->at("meta").at("history").size(), plots.at("history").at("iteration").size());
  // nk estimated, within the half of the impulse estimate that can hold a delay, and said how.
  const json& summary = result.at("summary");
  EXPECT_LT(summary.at("nk").get<int>(), 1500 / 2);
  EXPECT_FALSE(summary.at("nk_source").get<std::string>().empty());
  EXPECT_NE(summary.at("nk_source"), "given");
  // A warning exactly when the model is no better than zero or than the linear model of the same record.
  const double j = result.at("j_val_pct").get<double>(), linear = summary.at("linear_reference_J_pct").get<double>();
  EXPECT_EQ(result.at("warnings").size(), static_cast<std::size_t>((j >= 100.0) + (j > linear))) << result.at("warnings");
}

TEST_F(JobKindsTest, AnUntrainedNarxModelEndsWithAWarningNotInSilence) {
  use_plant("panel-exciter");
  run("excite", {{"samples", 3000}, {"validation_samples", 1000}, {"amplitude", 0.8}}, "j1");
  const json result = run("identify-narx",
                          {{"record", "j1"}, {"na", 2}, {"nb", 2}, {"nk", 1}, {"hidden", {3}}, {"max_iterations", 0}}, "j2");
  EXPECT_EQ(result.at("summary").at("nk_source"), "given");
  const double j = result.at("j_val_pct").get<double>(), linear = result.at("summary").at("linear_reference_J_pct").get<double>();
  ASSERT_GT(j, linear) << "random initial weights against a fitted linear model";
  ASSERT_FALSE(result.at("warnings").empty());
  const std::string last = result.at("warnings").back().get<std::string>();
  EXPECT_NE(last.find("worse than a linear model"), std::string::npos) << last;
  EXPECT_NE(last.find("nk 1, given"), std::string::npos) << last;
}

TEST_F(JobKindsTest, IdentifyNarxSeedsFrictionNodesWhenAsked) {
  use_plant("panel-exciter");
  run("excite", {{"samples", 3000}, {"validation_samples", 1000}, {"amplitude", 0.8}}, "j1");
  // no training: the seeded nodes are the whole difference between the two models
  const json common = {{"record", "j1"}, {"na", 4}, {"nb", 4}, {"hidden", {5}}, {"max_iterations", 0}};
  json seeded_params = common;
  seeded_params["friction_units"] = {2.0, 6.0};
  const json plain = run("identify-narx", common, "j2");
  const json seeded = run("identify-narx", seeded_params, "j3");
  EXPECT_FALSE(plain.at("summary").contains("friction_units"));
  const json& report = seeded.at("summary").at("friction_units");
  EXPECT_EQ(report.at("gains"), json({2.0, 6.0}));
  EXPECT_EQ(report.at("lags"), 1);
  EXPECT_GT(report.at("velocity_fit_r2").get<double>(), 0.5);
  const json a = *store_->model(plain.at("model_id").get<std::string>());
  const json b = *store_->model(seeded.at("model_id").get<std::string>());
  EXPECT_EQ(b.at("meta").at("friction_units"), report);
  const json& ta = a.at("params").at("theta");
  const json& tb = b.at("params").at("theta");
  const std::size_t inputs = 4 + 4 + 1;
  for (std::size_t i = 0; i < inputs; ++i) EXPECT_NEAR(tb[inputs + i].get<double>(), 3.0 * tb[i].get<double>(), 1e-12);
  for (std::size_t i = 2 * inputs; i < ta.size(); ++i) {
    if (i != 5 * inputs && i != 5 * inputs + 1) {
      EXPECT_EQ(ta[i], tb[i]) << "parameter " << i;
    }
  }
}


TEST_F(JobKindsTest, IdentifyNarxWeightedTrainsWithTheRecordsHarmonicWeights) {
  const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}, {"r", 3.0}}, "j1").at("model_id");
  run("excite", {{"signal", "control"}, {"feedforward_model", lq}, {"samples", 2000}, {"validation_samples", 1000}, {"seed", 4}},
      "j2");
  const json narx = {{"record", "j2"}, {"na", 2}, {"nb", 2}, {"nk", 2}, {"hidden", {3}}, {"max_iterations", 3}};
  json weighted_params = narx;
  weighted_params["weighted"] = true;
  const json weighted = run("identify-narx", weighted_params, "j3");
  const json plain = run("identify-narx", narx, "j4");
  EXPECT_EQ(weighted.at("summary").at("weighted"), true);
  EXPECT_EQ(plain.at("summary").at("weighted"), false);
  const models::NarxModel w = models::narx_model_from_json(*store_->model(weighted.at("model_id").get<std::string>()));
  const models::NarxModel p = models::narx_model_from_json(*store_->model(plain.at("model_id").get<std::string>()));
  EXPECT_EQ(w.meta.at("weighted"), true);
  // The same training written out with the library and the record's weights gives the job's model.
  const ExcitationRecord r = excitation_record_from_result(results_.at("j2"), kFs, "j2");
  const models::Scaling scaling = models::scaling_from_data(r.u_est, r.y_est);
  models::NarxModel start = models::NarxModel::with_structure({2, 2, 2, {3}}, scaling, kFs);
  start.net.initialize(1.0, 1);
  models::TrainingOptions options;
  options.modes = {models::TrainingMode::pem, models::TrainingMode::oem_d};
  options.optimizer = models::Optimizer::lm;
  options.max_iterations = 3;
  options.weight_decay = models::kDefaultLmWeightDecay;  // the job's defaults, as identify narx's: D starts there and
  options.evidence_decay = models::EvidenceDecay::all_modes;  // is re-estimated by the evidence
  options.weights = r.w_est;
  options.validation_weights = r.w_val;
  options.init = init_samples(r.u_val.size());  // as the job: the J it reports is the J training selects on
  const models::TrainingResult direct = models::train_narx(start, scaling.scale_u(r.u_est), scaling.scale_y(r.y_est),
                                                           scaling.scale_u(r.u_val), scaling.scale_y(r.y_val), options);
  EXPECT_EQ(w.net.parameters(), direct.model.net.parameters());
  EXPECT_NE(w.net.parameters(), p.net.parameters());
}

TEST_F(JobKindsTest, ControlExcitationAndWeightsAreRefusedWhereTheyCannotApply) {
  const std::string linear = store_reference_model();
  EXPECT_EQ(refusal("excite", {{"signal", "control"}}), "params.feedforward_model: required");
  EXPECT_NE(refusal("excite", {{"signal", "control"}, {"feedforward_model", linear}}).find("expected lq_feedforward"),
            std::string::npos);
  EXPECT_EQ(refusal("excite", {{"signal", "noise"}, {"feedforward_model", linear}}), "params.feedforward_model: unknown field");
  const std::string lq = run("design-lq", {{"plant_model", linear}, {"r", 3.0}}, "j1").at("model_id");
  EXPECT_EQ(refusal("excite", {{"signal", "control"}, {"feedforward_model", lq}, {"samples", 500}}),
            "params.samples: a control excitation needs at least 1000 samples, got 500");
  EXPECT_NE(refusal("excite", {{"signal", "control"}, {"feedforward_model", lq}, {"validation_samples", 500}})
                .find("params.validation_samples: must be 0 (none) or at least 1000"),
            std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"weighted", true}}).find("params.weighted: the weights come with a control excitation"),
            std::string::npos);
  run("excite", {{"samples", 1000}, {"validation_samples", 0}}, "j5");
  EXPECT_NE(refusal("identify-narx", {{"record", "j5"}, {"weighted", true}}).find("job j5's record has none"), std::string::npos);
  EXPECT_EQ(refusal("identify-narx", {{"weighted", "yes"}}), "params.weighted: expected true or false, got \"yes\"");
  // A plain record is fine unweighted.
  EXPECT_EQ(validate_job_params("identify-narx", {{"record", "j5"}}, env_).at("weighted"), false);
}

}  // namespace
}  // namespace panelbass::api::job_testing

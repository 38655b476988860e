// The excite job: the backend's response recorded, a multisine within its peak, and the control excitation
// that plays the LQ feedforward's drive and weighs its harmonics.

#include <gtest/gtest.h>

#include "api/record_store.h"
#include "tests/api/jobs/job_test_fixture.h"

namespace panelbass::api::job_testing {
namespace {

// ----- work --------------------------------------------------------------------------------------------

TEST_F(JobKindsTest, ExciteRecordsTheBackendsResponse) {
  FakeControl control("j1");
  const json result = run("excite", {{"samples", 3000}, {"validation_samples", 1000}, {"amplitude", 0.5}, {"seed", 4}}, control);
  expect_progress(control);
  EXPECT_EQ(excitations_, 2);
  EXPECT_LE(max_drive_, 0.5);
  EXPECT_EQ(result.at("samples"), 3000);
  EXPECT_EQ(result.at("validation_samples"), 1000);
  EXPECT_EQ(result.at("fs"), kFs);
  const json& record = result.at("record");
  ASSERT_EQ(record.at("u_est").size(), 3000u);
  ASSERT_EQ(record.at("y_val").size(), 1000u);
  // The response is the reference system's to this drive (within the added noise).
  Eigen::VectorXd u(3000), y(3000);
  for (int k = 0; k < 3000; ++k) {
    u[k] = record.at("u_est")[k].get<double>();
    y[k] = record.at("y_est")[k].get<double>();
  }
  EXPECT_LT((y - testing_support::simulate(reference_system(), u)).cwiseAbs().maxCoeff(), 1e-3);
  // Uniform noise in [−0.5, 0.5]: rms 0.5/√3.
  EXPECT_NEAR(result.at("rms_drive").get<double>(), 0.5 / std::sqrt(3.0), 0.01);
  expect_plot(result.at("plots").at("fit"), {"t", "drive", "measured"});
  EXPECT_EQ(result.at("plots").at("fit").at("t").size(), 2000u);
}

TEST_F(JobKindsTest, ExciteMultisineStaysWithinItsPeak) {
  const json result = run("excite", {{"signal", "multisine"}, {"samples", 5000}, {"validation_samples", 0}, {"amplitude", 0.8}}, "j1");
  EXPECT_LE(max_drive_, 0.8 + 1e-12);
  EXPECT_GT(max_drive_, 0.7);
  EXPECT_EQ(result.at("record").at("u_val").size(), 0u);
  EXPECT_EQ(excitations_, 1);
}


TEST_F(JobKindsTest, ControlExcitationPlaysTheFeedforwardsDriveAndWeighsItsHarmonics) {
  const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}, {"r", 3.0}}, "j1").at("model_id");
  FakeControl control("j2");
  const json result = run("excite",
                          {{"signal", "control"}, {"feedforward_model", lq}, {"samples", 3000}, {"validation_samples", 1000},
                           {"sine_peak", 0.5}, {"seed", 4}},
                          control);
  expect_progress(control);
  const ExcitationRecord r = excitation_record_from_result(result, kFs, "j2");
  ASSERT_EQ(r.u_est.size(), 3000);
  ASSERT_EQ(r.u_val.size(), 1000);
  // The drive is the chain's output for the design's program, as panelbass simulate --signal control makes
  // it (models::control_record behind the controller's 20-1200 Hz band-pass), seed 4 then 5.
  const models::LqFeedforward ff = models::lq_feedforward_from_json(*store_->model(lq));
  const std::vector<dsp::Biquad> band = dsp::butterworth_band(2, 20.0, 1200.0, kFs);
  models::FeedbackDesignOptions design;
  design.sine_peak = 0.5;
  design.samples = 3000;
  const models::ControlRecord est = models::control_record(ff, band, design, 4);
  design.samples = 1000;
  const models::ControlRecord val = models::control_record(ff, band, design, 5);
  EXPECT_EQ(r.u_est, est.u);
  EXPECT_EQ(r.u_val, val.u);
  EXPECT_LE(std::max(r.u_est.cwiseAbs().maxCoeff(), r.u_val.cwiseAbs().maxCoeff()), 1.0);
  // The weights are those of the recorded response.
  EXPECT_EQ(r.w_est, models::harmonic_weights(est, r.y_est, kFs));
  EXPECT_EQ(r.w_val, models::harmonic_weights(val, r.y_val, kFs));
  EXPECT_GE(r.w_est.minCoeff(), 0.0);
  EXPECT_GT(r.w_est.maxCoeff(), 0.0);
  EXPECT_EQ(result.at("signal"), "control");
}

// With a record store (as the server runs it), the record is kept there once: the job's result names it in a few
// hundred bytes, the jobs that read "record":"j…" read the same samples back, and a result that holds its record
// inline (a job file written before) still reads.
TEST_F(JobKindsTest, ExciteKeepsItsRecordOnceInTheRecordStore) {
  RecordStore records(dir_ / "store");
  env_.records = &records;
  const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}, {"r", 3.0}}, "j1").at("model_id");
  const json result = run("excite",
                          {{"signal", "control"}, {"feedforward_model", lq}, {"samples", 3000}, {"validation_samples", 1000},
                           {"sine_peak", 0.5}, {"seed", 4}},
                          "j2");
  ASSERT_FALSE(result.contains("record"));
  ASSERT_TRUE(result.at("record_id").is_string());
  EXPECT_EQ(result.at("record_columns"), json({"u", "y", "w"}));
  const std::optional<StoredRecord> entry = records.find(result.at("record_id").get<std::string>());
  ASSERT_TRUE(entry);
  EXPECT_EQ(entry->samples, 4000u);
  EXPECT_EQ(entry->name, "excitation of j2");
  // Read back: the same samples (17 significant digits), weights included, split where the job split it.
  const ExcitationRecord back = excitation_record_from_result(result, kFs, "j2", &records);
  json inline_result = result;
  inline_result.erase("record_id");
  inline_result["record"] = excitation_record_to_json(back);
  const ExcitationRecord old_style = excitation_record_from_result(inline_result, kFs, "j2");
  // The job file keeps the record's id, not its samples: but for its plot of 2000 samples, a few hundred bytes.
  json without_plots = result;
  without_plots.erase("plots");
  EXPECT_LT(without_plots.dump().size(), 1000u) << without_plots.dump();
  EXPECT_GT(inline_result.dump().size(), 2 * result.dump().size());
  ASSERT_EQ(back.u_est.size(), 3000);
  ASSERT_EQ(back.w_val.size(), 1000);
  EXPECT_EQ(back.u_est, old_style.u_est);
  EXPECT_EQ(back.w_val, old_style.w_val);
  // Against the control record computed independently (seed 4 for estimation, 5 for validation).
  const models::LqFeedforward ff = models::lq_feedforward_from_json(*store_->model(lq));
  models::FeedbackDesignOptions design;
  design.sine_peak = 0.5;
  design.samples = 3000;
  EXPECT_EQ(back.u_est, models::control_record(ff, dsp::butterworth_band(2, 20.0, 1200.0, kFs), design, 4).u);
  // The jobs that take "record":"j2" read it (a weighted NARX needs its weights).
  const json narx = run("identify-narx", {{"record", "j2"}, {"na", 2}, {"nb", 2}, {"hidden", {2}}, {"max_iterations", 1},
                                          {"weighted", true}}, "j3");
  EXPECT_TRUE(narx.contains("model_id"));
  // Gone from the store: named.
  ASSERT_TRUE(records.remove(entry->id));
  const std::string gone = one_line_error<std::invalid_argument>([&] { validate_job_params("identify-linear", {{"record", "j2"}}, env_); });
  EXPECT_NE(gone.find("params.record: job j2 kept its record as " + entry->id + ", which is no longer stored"), std::string::npos)
      << gone;
}

}  // namespace
}  // namespace panelbass::api::job_testing

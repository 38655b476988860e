// The excite job: the backend's response recorded, a multisine within its peak, and the control excitation
// that plays the LQ feedforward's drive and weighs its harmonics.

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace panelbass::api::job_testing

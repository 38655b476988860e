// The identify linear, identify narx, analyze and evaluate use cases: a request out of range is refused naming its
// field, and what each verb makes is what the library makes of the same request (the doors' parity is
// tests/api/jobs/usecase_parity_identify_test.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "models/narx/narx_training.h"
#include "models/preprocess/scaling.h"
#include "usecases/analyze.h"
#include "usecases/evaluate.h"
#include "usecases/identify_linear.h"
#include "usecases/identify_narx.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

// The field and words of the RequestError `check` throws.
template <typename Check>
std::string refusal(Check&& check) {
  try {
    check();
  } catch (const RequestError& e) {
    return e.what();
  }
  return "(accepted)";
}

// A noise-free record of y(k) = 1.2·y(k−1) − 0.5·y(k−2) + 0.4·u(k−1) + 0.2·u(k−2) driven by a deterministic
// broadband sequence.
void second_order_record(Eigen::VectorXd& u, Eigen::VectorXd& y, Eigen::Index n) {
  u.resize(n);
  y.setZero(n);
  for (Eigen::Index k = 0; k < n; ++k) u[k] = std::sin(0.37 * static_cast<double>(k * k % 997));
  for (Eigen::Index k = 2; k < n; ++k) y[k] = 1.2 * y[k - 1] - 0.5 * y[k - 2] + 0.4 * u[k - 1] + 0.2 * u[k - 2];
}

TEST(IdentifyRequests, OutOfRangeFieldsAreNamed) {
  IdentifyLinearRequest linear;
  linear.order = 201;
  EXPECT_EQ(refusal([&] { check(linear); }), "order: must be within 1..200, got 201");
  linear.order = 8;
  linear.method = "svd";
  EXPECT_EQ(refusal([&] { check(linear); }), "method: must be fir, arx, oe, zhu or backx, got \"svd\"");
  EXPECT_EQ(refusal([] { check_scan({2, 6}, false); }),
            "scan: an order scan needs validation data: the order is picked by validation J");
  EXPECT_EQ(refusal([] { check_scan({6, 2}, true); }), "scan: expected [from, to] with 1 <= from <= to <= 200, got [6, 2]");

  IdentifyNarxRequest narx;
  narx.grow = 3;
  narx.friction_units = {2.0};
  EXPECT_EQ(refusal([&] { check(narx); }), "friction_units: cannot be combined with grow (growth starts afresh)");
  narx = {};
  narx.optimizer = "sd";
  narx.weight_decay = 0.1;
  EXPECT_EQ(refusal([&] { check(narx); }), "weight_decay: the sd optimizer has none: leave it out or give 0");
  narx.weight_decay.reset();  // sd's default: none
  EXPECT_EQ(refusal([&] { check(narx); }), "(accepted)");
  narx.optimizer = "linesearch";  // no Gauss-Newton matrix either: the evidence's default is off, asking for it refused
  EXPECT_EQ(evidence_decay_of(narx), "off");
  EXPECT_EQ(refusal([&] { check(narx); }), "(accepted)");
  narx.evidence_decay = "oem";
  EXPECT_EQ(refusal([&] { check(narx); }),
            "evidence_decay: needs the lm optimizer (the evidence is read off its Gauss-Newton matrix), the optimizer is "
            "linesearch: leave it out or give off");
  narx = {};
  second_order_record(narx.u_est, narx.y_est, 400);
  narx.prune = true;
  EXPECT_EQ(refusal([&] { check(narx); }), "prune: needs validation data (the pruning stops by validation J)");

  AnalyzeRequest analyze;
  analyze.u = Eigen::VectorXd::Zero(50);
  analyze.y = Eigen::VectorXd::Zero(50);
  EXPECT_EQ(refusal([&] { check(analyze); }), "init: 50 is not shorter than the data (50 samples)");

  EvaluateRequest evaluate;
  evaluate.probes_hz = {40.0, 1600.0};
  EXPECT_EQ(refusal([&] { check(evaluate); }), "probes_hz: each must be within (0, 1500) Hz, got 1600");
  evaluate = {};
  evaluate.plant = "tuba";
  EXPECT_NE(refusal([&] { check(evaluate); }).find("plant: must be a preset"), std::string::npos);
}

TEST(IdentifyRequests, ArxOnNoiseFreeDataOfItsOwnOrderFindsTheSystem) {
  IdentifyLinearRequest q;
  second_order_record(q.u_est, q.y_est, 2000);
  q.fs = 1000.0;
  q.method = "arx";
  q.order = 2;
  q.delay = 1;
  SilentProgress quiet;
  const IdentifyLinearReport r = identify_linear(q, quiet);
  // The denominator is the system's, z² − 1.2z + 0.5 (scaling the data leaves it unchanged).
  ASSERT_EQ(r.model.tf.na(), 2);
  EXPECT_NEAR(r.model.tf.a[0], -1.2, 1e-3);  // the scaling's offsets leave a trace of the start's transient
  EXPECT_NEAR(r.model.tf.a[1], 0.5, 1e-3);
  EXPECT_EQ(r.summary.at("delay"), 1);
  EXPECT_LT(r.summary.at("J_est_pct").get<double>(), 1e-2);
  EXPECT_TRUE(r.warnings.empty());
}

TEST(IdentifyRequests, OneNarxTrainingIsTheLibrarysTrainingOfTheSameStart) {
  IdentifyNarxRequest q;
  second_order_record(q.u_est, q.y_est, 600);
  second_order_record(q.u_val, q.y_val, 300);
  q.fs = 1000.0;
  q.na = 2;
  q.nb = 2;
  q.hidden = {3};
  q.max_iterations = 3;
  q.seed = 5;
  SilentProgress quiet;
  const IdentifyNarxReport r = identify_narx(q, quiet);
  // The same start (the structure scaled to the estimation record, the weights of seed 5) trained by the library.
  const models::Scaling scaling = models::scaling_from_data(q.u_est, q.y_est);
  models::NarxModel start = models::NarxModel::with_structure({2, 2, 0, {3}}, scaling, q.fs);
  start.net.initialize(1.0, 5);
  models::TrainingOptions options;
  options.max_iterations = 3;
  options.weight_decay = models::kDefaultLmWeightDecay;  // the starting D, re-estimated by the evidence (the default)
  options.evidence_decay = models::EvidenceDecay::all_modes;
  options.init = 30;  // a tenth of the 300 validation samples, below the request's 50
  const models::TrainingResult direct = models::train_narx(start, scaling.scale_u(q.u_est), scaling.scale_y(q.y_est),
                                                           scaling.scale_u(q.u_val), scaling.scale_y(q.y_val), options);
  EXPECT_EQ(r.model.net.parameters(), direct.model.net.parameters());
  EXPECT_EQ(r.summary.at("nk_source"), "given");
  EXPECT_EQ(r.summary.at("iterations"), direct.iterations);
  EXPECT_EQ(r.model.meta.at("seed"), 5);
}

}  // namespace
}  // namespace panelbass::usecases

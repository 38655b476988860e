#include "usecases/verify.h"

#include <gtest/gtest.h>

#include "models/control/lq_feedforward.h"
#include "models/linear/linear_model.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

// A first-order plant model at 3000 Hz, y(k) = 0.5·y(k−1) + u(k−1).
models::LinearModel first_order() {
  models::LinearModel m;
  m.tf.a = Eigen::VectorXd::Constant(1, -0.5);
  m.tf.b = Eigen::VectorXd::Constant(1, 1.0);
  m.tf.nk = 1;
  m.fs = 3000.0;
  m.method = "oe";
  return m;
}

// An LQ feedforward file designed behind `low`-`high` Hz of `order` (as `design lq` records it in the meta).
nlohmann::json lq_file(double low, double high, int order) {
  models::LqFeedforward ff = models::design_lq(first_order(), models::LqWeights{});
  ff.meta = {{"bandpass", {low, high}}, {"bandpass_order", order}};
  return models::lq_feedforward_to_json(ff);
}

TEST(Verify, AnLqFeedforwardRunsBehindTheBandPassItWasDesignedFor) {
  VerifyRequest q;
  q.feedforward_model = lq_file(30.0, 900.0, 4);
  q.feedforward_name = "ff";
  q.chain.fs = 3000.0;
  q.chain.band_pass.bypass = true;  // the engine's band-pass bypassed: the controller still runs behind its own
  const engine::ChainConfig chain = verified_chain(q);
  EXPECT_EQ(chain.band_pass.design.low.value, 30.0);
  EXPECT_EQ(chain.band_pass.design.high.value, 900.0);
  EXPECT_EQ(chain.band_pass.design.order, 4);
  EXPECT_FALSE(chain.band_pass.bypass);
  ASSERT_TRUE(chain.feedforward.has_value());
  EXPECT_EQ(chain.feedforward->model, q.feedforward_model);
  EXPECT_FALSE(chain.feedback.has_value()) << "no feedback asked for";
}

TEST(Verify, APlantModelIsNoControllerAndTheFieldIsNamed) {
  VerifyRequest q;
  q.feedforward_model = models::linear_model_to_json(first_order());
  q.feedforward_name = "lin";
  q.chain.fs = 3000.0;
  try {
    verified_chain(q);
    FAIL() << "a plant model was taken as a feedforward";
  } catch (const RequestError& e) {
    EXPECT_EQ(e.field(), "feedforward_model");
    EXPECT_NE(e.problem().find("the feedforward slot takes"), std::string::npos) << e.problem();
  }
  q.feedforward_model = lq_file(20.0, 1200.0, 2);
  q.feedback_name = "lq as feedback";
  q.feedback_model = q.feedforward_model;
  try {
    verified_chain(q);
    FAIL() << "an LQ feedforward was taken as a feedback";
  } catch (const RequestError& e) {
    EXPECT_EQ(e.field(), "feedback_model");
  }
}

TEST(Verify, TheDefaultProbesOneLevelAndProbesOutOfRangeAreNamed) {
  VerifyRequest q;
  EXPECT_EQ(q.settings.levels, std::vector<double>{0.2});
  q.feedforward_name = "ff";
  q.chain.fs = 3000.0;
  EXPECT_NO_THROW(check(q));
  q.settings.frequencies = {800.0};
  try {
    check(q);
    FAIL() << "800 Hz is above fs/4";
  } catch (const RequestError& e) {
    EXPECT_EQ(e.field(), "frequencies");
  }
  VerifyRequest none;
  none.chain.fs = 3000.0;
  EXPECT_THROW(check(none), RequestError) << "no feedforward";
}

}  // namespace
}  // namespace panelbass::usecases

// The neural feedback controller's design records: the program through band-pass and LQ feedforward,
// its levels, and its determinism.
#include <gtest/gtest.h>

#include "dsp/butterworth.h"
#include "models/feedback_design.h"
#include "models/state_space.h"
#include "tests/support/linear_systems.h"

namespace panelbass::models {
namespace {

LinearModel resonant_model() {
  LinearModel m;
  Eigen::VectorXcd poles(2);
  poles << std::polar(0.97, 0.3), std::polar(0.97, -0.3);
  m.tf.a = polynomial_from_roots(poles).tail(2);
  m.tf.b = Eigen::Vector2d(0.05, 0.03);
  m.tf.nk = 1;
  m.fs = 3000.0;
  return m;
}

TEST(FeedbackDesignTest, ControlRecordIsTheProgramThroughBandPassAndFeedforward) {
  const LqFeedforward ff = design_lq(resonant_model(), {1e-3, 20.0});
  const std::vector<dsp::Biquad> bp = dsp::butterworth_bandpass(2, 20.0, 1200.0, 3000.0);
  FeedbackDesignOptions o;
  o.samples = 6000;
  o.sine_peak = 0.6;
  const ControlRecord r = control_record(ff, bp, o, 3);
  ASSERT_EQ(r.u.size(), 6000);
  // u and y_desired are [7B] of the band-passed program, recomputed here with plain loops
  dsp::SosFilter filter(bp);
  const Eigen::VectorXd p = filter.process(r.program);
  const StateSpace& s = ff.plant;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(s.order());
  for (Eigen::Index k = 0; k < p.size(); ++k) {
    ASSERT_NEAR(r.u[k], -ff.L.dot(x) + p[k], 1e-10) << k;
    ASSERT_NEAR(r.y_desired[k], s.C.dot(x) + s.D * p[k], 1e-10) << k;
    x = (s.A - s.B * ff.L) * x + s.B * p[k];
  }
  // the noise half stays within the safe range; the sine half's steady peaks do not pass sine_peak (10 % for the
  // fade-in transients)
  EXPECT_LE(r.u.head(3000).cwiseAbs().maxCoeff(), 1.0 + 1e-9);
  EXPECT_LE(r.u.tail(2900).cwiseAbs().maxCoeff(), 0.6 * 1.1);
  // deterministic in the seed, different for another
  EXPECT_EQ(control_record(ff, bp, o, 3).program, r.program);
  EXPECT_NE(control_record(ff, bp, o, 4).program, r.program);
}

TEST(FeedbackDesignTest, RefusesBadOptions) {
  const LqFeedforward ff = design_lq(resonant_model(), {1e-3, 20.0});
  FeedbackDesignOptions o;
  o.sine_peak = 1.5;
  EXPECT_THROW(control_record(ff, {}, o, 1), std::invalid_argument);
  o = {};
  o.sine_high_hz = 2000.0;
  EXPECT_THROW(control_record(ff, {}, o, 1), std::invalid_argument);
  o = {};
  o.samples = 10;
  EXPECT_THROW(control_record(ff, {}, o, 1), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

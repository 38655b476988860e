// Locating a residual: each measure against a residual built with a known cause — a linear error in a band
// (FRF error), odd or even distortion of a periodic record, a dependence on the state or on the direction
// of motion, a change of level at a known time — and against plain noise, where none may be reported.
#include "models/diagnosis/diagnosis_locate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dsp/excitation.h"
#include "models/diagnosis/diagnosis_terms.h"
#include "models/linear/transfer_function.h"
#include "tests/support/linear_systems.h"

namespace panelbass::models {
namespace {

using testing_support::gaussian;

constexpr double kLocateFs = 3000.0;
constexpr Eigen::Index kLocateN = 30000;

// A resonator at 600 Hz (poles at radius 0.97), unit gain at its peak.
TransferFunction resonator_600() {
  const double w = 2.0 * std::numbers::pi * 600.0 / kLocateFs, r = 0.97;
  TransferFunction tf;
  tf.a = Eigen::Vector2d(-2.0 * r * std::cos(w), r * r);
  tf.b = Eigen::VectorXd::Ones(1);
  tf.nk = 0;
  tf.b /= std::abs(tf.response(600.0, kLocateFs));
  return tf;
}

const StateProfile& profile(const ResidualLocation& l, const std::string& state) {
  for (const StateProfile& p : l.states)
    if (p.state == state) return p;
  throw std::logic_error("no profile of " + state);
}

TEST(LocateResidual, AnFrfErrorIsFoundInItsBandWithItsRelativeSize) {
  // y = u + 0.2·R(u) + noise, simulated as u: the residual's linear part is 0.2·R, peaking at 600 Hz where
  // H_ue/H_uy = 0.2·R/(1 + 0.2·R).
  const Eigen::VectorXd u = gaussian(kLocateN, 1.0, 1);
  const TransferFunction r = resonator_600();
  const Eigen::VectorXd y = u + 0.2 * filter_through(r, u) + gaussian(kLocateN, 0.05, 2);
  const ResidualLocation l = locate_residual(u, y, u, kLocateFs, 0);
  ASSERT_TRUE(l.frf_error.significant);
  EXPECT_NEAR(l.frf_error.frequency_hz, 600.0, 15.0);
  EXPECT_LT(l.frf_error.band_low_hz, 600.0);
  EXPECT_GT(l.frf_error.band_high_hz, 600.0);
  EXPECT_GT(l.frf_error.band_low_hz, 450.0) << "the band is the resonator's, not the whole spectrum";
  EXPECT_LT(l.frf_error.band_high_hz, 750.0);
  const std::complex<double> error = 0.2 * r.response(l.frf_error.frequency_hz, kLocateFs);
  EXPECT_NEAR(l.frf_error.relative_db, 20.0 * std::log10(std::abs(error / (1.0 + error))), 1.0);
}

TEST(LocateResidual, PlainNoiseHasNoFrfErrorNoStateDependenceAndNoChange) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const Eigen::VectorXd u = gaussian(kLocateN, 1.0, 10 * seed);
    const Eigen::VectorXd y_sim = filter_through(resonator_600(), u);
    const Eigen::VectorXd y = y_sim + gaussian(kLocateN, 0.1, 10 * seed + 1);
    const ResidualLocation l = locate_residual(u, y, y_sim, kLocateFs, 0);
    EXPECT_FALSE(l.frf_error.significant) << "seed " << seed << ": coherence " << l.frf_error.coherence;
    EXPECT_FALSE(l.distortion.periodic);
    for (const StateProfile& p : l.states) {
      EXPECT_LT(p.shape_chi2, 3.0) << p.state << ", seed " << seed;
      EXPECT_LT(std::abs(p.direction_t), 4.0) << p.state << ", seed " << seed;
      EXPECT_NEAR(p.level_ratio, 1.0, 0.1) << p.state << ", seed " << seed;
    }
    EXPECT_LT(std::abs(l.change_t), 5.0) << "seed " << seed;
    EXPECT_NEAR(l.change_ratio, 1.0, 0.15) << "seed " << seed;
    EXPECT_NEAR(l.effective_samples, static_cast<double>(kLocateN), 0.1 * kLocateN) << "white noise: every sample counts";
  }
}

// A random-odd multisine (peak 1, rms ≈ 0.35), six periods of 1024 samples, and its output through
// y = u + a2·u² + a3·u³ + noise of rms 0.001 (the distortion is 20–30 dB above it).
struct PeriodicRecord {
  Eigen::VectorXd u, y;
};
PeriodicRecord periodic_record(double a2, double a3) {
  dsp::MultisineSpec spec;
  spec.period = 1024;
  spec.periods = 6;
  spec.fs = kLocateFs;
  spec.f_max = 1000.0;
  spec.lines = dsp::MultisineLines::random_odd;
  spec.amplitude = 1.0;
  spec.seed = 4;
  PeriodicRecord r;
  r.u = dsp::multisine(spec).signal;
  r.y = r.u + a2 * r.u.array().square().matrix() + a3 * r.u.array().cube().matrix() + gaussian(r.u.size(), 0.001, 5);
  return r;
}

TEST(LocateResidual, EvenDistortionOfAPeriodicRecordLandsOnTheEmptyEvenLines) {
  const PeriodicRecord r = periodic_record(0.2, 0.0);
  const ResidualLocation l = locate_residual(r.u, r.y, r.u, kLocateFs, 0);
  ASSERT_TRUE(l.distortion.periodic);
  EXPECT_EQ(l.distortion.period, 1024);
  EXPECT_EQ(l.distortion.periods, 5);
  EXPECT_TRUE(l.distortion.odd_lines_only);
  EXPECT_GT(l.distortion.residual_even_db, 20.0);
  EXPECT_LT(l.distortion.residual_odd_db, l.distortion.threshold_db);
  // A simulation that has the square leaves nothing at the even lines; the output still has it.
  const Eigen::VectorXd with_square = r.u + 0.2 * r.u.array().square().matrix();
  const ResidualLocation modelled = locate_residual(r.u, r.y, with_square, kLocateFs, 0);
  EXPECT_GT(modelled.distortion.output_even_db, 20.0);
  EXPECT_LT(modelled.distortion.residual_even_db, modelled.distortion.threshold_db);
}

TEST(LocateResidual, OddDistortionOfAPeriodicRecordLandsOnTheEmptyOddLines) {
  const PeriodicRecord r = periodic_record(0.0, 0.2);
  const ResidualLocation l = locate_residual(r.u, r.y, r.u, kLocateFs, 0);
  ASSERT_TRUE(l.distortion.periodic);
  EXPECT_GT(l.distortion.residual_odd_db, 20.0);
  EXPECT_LT(l.distortion.residual_even_db, l.distortion.threshold_db);
}

TEST(LocateResidual, ACubicResidualShowsAgainstTheOutputItDependsOn) {
  // e = 0.05·ŷn³ + noise, ŷn the simulated output scaled to unit rms: the bin means follow the cube.
  const Eigen::VectorXd u = gaussian(kLocateN, 1.0, 7);
  const Eigen::VectorXd y_sim = filter_through(resonator_600(), u);
  const double rms = std::sqrt(y_sim.squaredNorm() / kLocateN);
  const Eigen::VectorXd cube = (y_sim / rms).array().cube();
  const Eigen::VectorXd y = y_sim + 0.05 * cube + gaussian(kLocateN, 0.05, 8);
  const ResidualLocation l = locate_residual(u, y, y_sim, kLocateFs, 0);
  const StateProfile& p = profile(l, "output");
  EXPECT_GT(p.shape_chi2, 20.0);
  EXPECT_GT(p.level_ratio, 2.0);
  ASSERT_EQ(p.mean.size(), 12);
  for (Eigen::Index b = 0; b < 12; ++b) {
    // The mean of 0.05·x³ over a bin is close to 0.05·(the bin's mean x)³ (exact within ~10 % at the ends).
    const double expected = 0.05 * std::pow(p.centre[b], 3);
    EXPECT_NEAR(p.mean[b], expected, 0.015 + 0.35 * std::abs(expected)) << "bin " << b;
  }
  EXPECT_GT(l.output_level_ratio, 2.0);
}

TEST(LocateResidual, AFrictionLikeResidualShowsAsADirectionOfMotion) {
  // e = 0.02·sign(dŷ/dt) + noise: the residual's mean differs by 0.04 between rising and falling output.
  const Eigen::VectorXd u = gaussian(kLocateN, 1.0, 9);
  const Eigen::VectorXd y_sim = filter_through(resonator_600(), u);
  Eigen::VectorXd y = y_sim + gaussian(kLocateN, 0.1, 10);
  for (Eigen::Index k = 1; k < kLocateN; ++k) y[k] += 0.02 * (y_sim[k] > y_sim[k - 1] ? 1.0 : -1.0);
  const ResidualLocation l = locate_residual(u, y, y_sim, kLocateFs, 0);
  EXPECT_GT(profile(l, "output").direction_t, 8.0);
}

TEST(LocateResidual, AChangeOfLevelIsDatedAndSized) {
  // The residual's rms triples at 60 % of the record.
  const Eigen::VectorXd u = gaussian(kLocateN, 1.0, 11);
  Eigen::VectorXd e = gaussian(kLocateN, 0.05, 12);
  const Eigen::Index onset = 6 * kLocateN / 10;
  e.tail(kLocateN - onset) *= 3.0;
  const ResidualLocation l = locate_residual(u, u + e, u, kLocateFs, 0);
  EXPECT_NEAR(l.change_time_s, static_cast<double>(onset) / kLocateFs, static_cast<double>(kLocateN) / 20.0 / kLocateFs);
  EXPECT_NEAR(l.change_ratio, 3.0, 0.3);
  EXPECT_GT(l.change_t, 10.0);
  EXPECT_GT(l.drift_ratio, 2.5);
}

// The verdicts against the thresholds the web UI hard-coded before they moved here (χ²/bin 3, |t| 4, the
// peak against its own threshold), written out as numbers rather than through the constants: a statistic
// just above and just below each.
TEST(DiagnosisVerdicts, EachStatisticIsSignificantJustAboveItsThresholdAndNotJustBelow) {
  EXPECT_TRUE(state_dependence_significant(3.001));
  EXPECT_FALSE(state_dependence_significant(2.999));
  EXPECT_FALSE(state_dependence_significant(1.0)) << "what noise gives";
  EXPECT_TRUE(t_significant(4.001));
  EXPECT_TRUE(t_significant(-4.001));
  EXPECT_FALSE(t_significant(3.999));
  EXPECT_FALSE(t_significant(-3.999));
  EXPECT_TRUE(peak_significant(1.401, 1.4));
  EXPECT_FALSE(peak_significant(1.399, 1.4));
}

// Every location carries the verdicts of its own statistics, and its JSON sends them unchanged: a cubic
// residual (its output profile significant), a friction-like one (its direction), a change of level, plain noise.
TEST(DiagnosisVerdicts, ALocationCarriesTheVerdictsOfItsStatistics) {
  const Eigen::VectorXd u = gaussian(kLocateN, 1.0, 21);
  const Eigen::VectorXd y_sim = filter_through(resonator_600(), u);
  const double rms = std::sqrt(y_sim.squaredNorm() / kLocateN);
  const Eigen::VectorXd noise = gaussian(kLocateN, 0.05, 22);
  Eigen::VectorXd friction = noise;
  for (Eigen::Index k = 1; k < kLocateN; ++k) friction[k] += 0.02 * (y_sim[k] > y_sim[k - 1] ? 1.0 : -1.0);
  Eigen::VectorXd change = noise;
  change.tail(kLocateN / 2) *= 3.0;
  const ResidualLocation cubic = locate_residual(u, y_sim + 0.05 * (y_sim / rms).array().cube().matrix() + noise, y_sim, kLocateFs, 0);
  const ResidualLocation directed = locate_residual(u, y_sim + friction, y_sim, kLocateFs, 0);
  const ResidualLocation changed = locate_residual(u, y_sim + change, y_sim, kLocateFs, 0);
  const ResidualLocation plain = locate_residual(u, y_sim + noise, y_sim, kLocateFs, 0);
  EXPECT_TRUE(profile(cubic, "output").shape_significant);
  EXPECT_TRUE(profile(directed, "output").direction_significant);
  EXPECT_TRUE(changed.change_significant);
  EXPECT_FALSE(plain.change_significant);
  for (const ResidualLocation* l : {&cubic, &directed, &changed, &plain}) {
    const nlohmann::json j = location_to_json(*l);
    EXPECT_EQ(l->peak_significant, l->peak_over_noise > l->peak_threshold);
    EXPECT_EQ(l->change_significant, std::abs(l->change_t) > 4.0) << "change_t " << l->change_t;
    EXPECT_EQ(j.at("peak_significant").get<bool>(), l->peak_significant);
    EXPECT_EQ(j.at("change_significant").get<bool>(), l->change_significant);
    ASSERT_EQ(j.at("states").size(), l->states.size());
    for (std::size_t i = 0; i < l->states.size(); ++i) {
      const StateProfile& p = l->states[i];
      EXPECT_EQ(p.shape_significant, p.shape_chi2 > 3.0) << p.state << ": χ² " << p.shape_chi2;
      EXPECT_EQ(p.direction_significant, std::abs(p.direction_t) > 4.0) << p.state << ": t " << p.direction_t;
      if (l == &plain) {
        EXPECT_FALSE(p.shape_significant || p.direction_significant) << p.state;
      }
      EXPECT_EQ(j["states"][i].at("shape_significant").get<bool>(), p.shape_significant);
      EXPECT_EQ(j["states"][i].at("direction_significant").get<bool>(), p.direction_significant);
    }
  }
}

}  // namespace
}  // namespace panelbass::models

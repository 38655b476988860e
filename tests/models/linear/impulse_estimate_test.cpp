// estimate_impulse on a known delayed, decaying impulse response driven by white noise: the delay,
// the length against the lag where |h| sinks below the least-squares noise level (computed here from
// h and σ_e alone), the 5 %-of-peak rule for the first tap, monotonicity in the noise, and the checks.
#include "models/linear/impulse_estimate.h"
#include "models/linear/data_survey.h"
#include "models/linear/fir_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "dsp/excitation.h"
#include "dsp/random.h"

namespace panelbass::models {
namespace {

constexpr Eigen::Index kSamples = 20000;
constexpr Eigen::Index kMaxLag = 200;
const double kSigmaU = 1.0 / std::sqrt(3.0);  // uniform noise in [−1, 1]

/// h(k) = 0.9^(k−d)·cos(0.3·(k−d)) for k ≥ d, zero before; lags 0..kMaxLag.
Eigen::VectorXd delayed_response(int d) {
  Eigen::VectorXd h = Eigen::VectorXd::Zero(kMaxLag + 1);
  for (Eigen::Index k = d; k <= kMaxLag; ++k) {
    const double m = static_cast<double>(k - d);
    h[k] = std::pow(0.9, m) * std::cos(0.3 * m);
  }
  return h;
}

/// y = h * u (from rest) + white Gaussian noise of standard deviation sigma_e.
Eigen::VectorXd respond(const Eigen::VectorXd& h, const Eigen::VectorXd& u, double sigma_e, std::uint64_t seed) {
  dsp::Rng rng(seed);
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    double s = 0.0;
    for (Eigen::Index j = 0; j < h.size() && j <= k; ++j) s += h[j] * u[k - j];
    y[k] = s + sigma_e * rng.gaussian();
  }
  return y;
}

/// Least-squares theory: an FIR coefficient estimated from N' = N − L equations carries noise of
/// standard deviation σ_e/(σ_u·√N'). Returns one past the last lag where |h| stands above the 99 %
/// band (2.58 of those standard deviations), i.e. where h sinks into the noise for good.
int expected_length(const Eigen::VectorXd& h, double sigma_e) {
  const double sigma_b = sigma_e / (kSigmaU * std::sqrt(static_cast<double>(kSamples - kMaxLag)));
  int last = 0;
  for (Eigen::Index k = 0; k < h.size(); ++k) {
    if (std::abs(h[k]) > 2.58 * sigma_b) last = static_cast<int>(k + 1);
  }
  return last;
}

TEST(ImpulseEstimateTest, DelayAndLengthOfAKnownResponse) {
  // Tolerance on the length ±15 %: the estimated taps scatter by σ_b, so near the threshold the
  // crossing of the 0.9^k envelope moves by about ln(3.58/2.58)/ln(1/0.9) ≈ 3 lags per σ; |cos(0.3k)|
  // has zeros every ~10.5 lags, so the last tap above threshold can jump by up to half of that; and a
  // single noise tap in the last 20-lag window may stand outside the band. 15 % of ~50–70 lags is
  // 8–10 lags, which covers these.
  const Eigen::VectorXd u = dsp::uniform_noise(kSamples, 1.0, 7);
  for (const int d : {0, 3, 5}) {
    const Eigen::VectorXd h = delayed_response(d);
    for (const double sigma_e : {0.03, 0.1, 0.3}) {
      const ImpulseEstimate e = estimate_impulse(u, respond(h, u, sigma_e, 99), kMaxLag);
      const int expected = expected_length(h, sigma_e);
      EXPECT_EQ(e.delay, d) << "σ_e " << sigma_e;
      EXPECT_GT(e.length, d);
      EXPECT_NEAR(e.length, expected, 0.15 * expected) << "d " << d << " σ_e " << sigma_e;
      ASSERT_EQ(e.response.size(), kMaxLag + 1);
    }
  }
}

TEST(ImpulseEstimateTest, ResponseIsImpulseResponseScaledByStdRatio) {
  // response ≈ h·σ_u/σ_y, each tap within 5 σ of the LS noise (σ_b·σ_u/σ_y); noise_band = 3.29 times
  // that noise level, within 20 % (it is measured from ~100 tail taps).
  const Eigen::VectorXd u = dsp::uniform_noise(kSamples, 1.0, 8);
  const Eigen::VectorXd h = delayed_response(4);
  const double sigma_e = 0.1;
  const Eigen::VectorXd y = respond(h, u, sigma_e, 100);
  const ImpulseEstimate e = estimate_impulse(u, y, kMaxLag);
  const Eigen::VectorXd uc = u.array() - u.mean();
  const Eigen::VectorXd yc = y.array() - y.mean();
  const double ratio = std::sqrt(uc.squaredNorm() / yc.squaredNorm());
  const double sigma_b = sigma_e / (kSigmaU * std::sqrt(static_cast<double>(kSamples - kMaxLag)));
  for (Eigen::Index k = 0; k <= kMaxLag; ++k) EXPECT_NEAR(e.response[k], h[k] * ratio, 5.0 * sigma_b * ratio) << k;
  EXPECT_NEAR(e.noise_band, 3.29 * sigma_b * ratio, 0.2 * 3.29 * sigma_b * ratio);
}

TEST(ImpulseEstimateTest, NoiseFreeDelayIsExact) {
  const Eigen::VectorXd u = dsp::uniform_noise(kSamples, 1.0, 9);
  for (const int d : {0, 1, 2, 7, 12}) {
    const ImpulseEstimate e = estimate_impulse(u, respond(delayed_response(d), u, 0.0, 1), kMaxLag);
    EXPECT_EQ(e.delay, d);
  }
}

TEST(ImpulseEstimateTest, FirstTapBelowFivePercentOfPeakIsNotAResponse) {
  // h(d) is a small leading tap, the decaying response (peak 1) starts at d+1. Noise small enough
  // that the noise band (~3e-4 in normalised units) is far below 5 % of the peak (~0.03).
  const int d = 4;
  const Eigen::VectorXd u = dsp::uniform_noise(kSamples, 1.0, 10);
  for (const double first : {0.03, -0.04, 0.08, -0.1}) {
    Eigen::VectorXd h = delayed_response(d + 1);
    h[d] = first;
    const ImpulseEstimate e = estimate_impulse(u, respond(h, u, 0.01, 101), kMaxLag);
    if (std::abs(first) < 0.05) {
      EXPECT_EQ(e.delay, d + 1) << "first tap " << first << " of the peak does not count";
    } else {
      EXPECT_EQ(e.delay, d) << "first tap " << first << " of the peak counts";
    }
  }
}

TEST(ImpulseEstimateTest, MoreNoiseGivesShorterLength) {
  // Each step triples σ_e; the 0.9^k envelope then crosses the threshold ln 3/ln(1/0.9) ≈ 10 lags
  // earlier, so the lengths must fall strictly.
  const Eigen::VectorXd u = dsp::uniform_noise(kSamples, 1.0, 11);
  const Eigen::VectorXd h = delayed_response(3);
  int previous = 1 << 30;
  for (const double sigma_e : {0.01, 0.03, 0.1, 0.3, 1.0}) {
    const ImpulseEstimate e = estimate_impulse(u, respond(h, u, sigma_e, 102), kMaxLag);
    EXPECT_LT(e.length, previous) << "σ_e " << sigma_e;
    previous = e.length;
  }
}

TEST(ImpulseEstimateTest, TooFewLagsThrows) {
  const Eigen::VectorXd u = dsp::uniform_noise(1000, 1.0, 12);
  EXPECT_THROW(estimate_impulse(u, u, 39), std::invalid_argument);
  EXPECT_THROW(estimate_impulse(u, u, 0), std::invalid_argument);
  EXPECT_NO_THROW(estimate_impulse(u, respond(delayed_response(2).head(41), u, 0.01, 5), 40));
}

TEST(ImpulseEstimateTest, UnequalLengthsThrow) {
  EXPECT_THROW(estimate_impulse(dsp::uniform_noise(1000, 1.0, 13), dsp::uniform_noise(999, 1.0, 14), 40),
               std::invalid_argument);
}

TEST(ImpulseEstimateTest, TooShortRecordThrows) {
  // N ≥ 2·(max_lag+1) is required: 81 samples cannot support 41 lags.
  const Eigen::VectorXd u = dsp::uniform_noise(81, 1.0, 15);
  EXPECT_THROW(estimate_impulse(u, dsp::uniform_noise(81, 1.0, 16), 40), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

namespace panelbass::models {
namespace {

TEST(ImpulseEstimateTest, ABandLimitedMultisineInputGivesTheResponseInItsBandAndTheDelay) {
  // A multisine exciting 20–1000 Hz of 3000 Hz leaves the normal equations singular outside its band; the
  // ridge gives no response there and the true one inside it. The estimate is then h band-limited, whose
  // pre-ringing may show one sample before the dead time of 3, never after it.
  dsp::MultisineSpec spec;
  spec.period = 4096;
  spec.periods = 5;
  spec.f_min = 20.0;
  spec.f_max = 1000.0;
  spec.seed = 3;
  const Eigen::VectorXd u = dsp::multisine(spec).signal;
  const Eigen::VectorXd h = delayed_response(3);
  const Eigen::VectorXd y = respond(h, u, 1e-3, 4);
  EXPECT_THROW(estimate_fir(u, y, kMaxLag + 1), std::invalid_argument) << "without the ridge: singular";
  const Eigen::VectorXd b = estimate_fir(u, y, kMaxLag + 1, 1e-3);
  const auto response = [](const Eigen::VectorXd& taps, double f) {
    std::complex<double> s = 0.0;
    for (Eigen::Index k = 0; k < taps.size(); ++k) s += taps[k] * std::polar(1.0, -2.0 * std::numbers::pi * f * k / 3000.0);
    return s;
  };
  for (const double f : {100.0, 300.0, 600.0, 900.0})
    EXPECT_LT(std::abs(response(b, f) - response(h, f)), 0.02 * std::abs(response(h, f))) << f << " Hz";
  const ImpulseEstimate e = estimate_impulse(u, y, kMaxLag);
  EXPECT_GE(e.delay, 2);
  EXPECT_LE(e.delay, 3);
}

// The second half of the lags is taken for noise, so a delay can only be read in the first: a response
// that starts at lag 150 of 200 is no delay the window supports (the API once reported nk = 1001, the window's
// end, for a record where no tap stood out). None is found and none is assumed.
TEST(ImpulseEstimateTest, ADelayNeverComesFromTheHalfTakenForNoise) {
  const Eigen::VectorXd u = dsp::uniform_noise(kSamples, 1.0, 9);
  const ImpulseEstimate late = estimate_impulse(u, respond(delayed_response(150), u, 0.01, 3), kMaxLag);
  EXPECT_FALSE(late.delay_found);
  EXPECT_EQ(late.delay, 0);
  const ImpulseEstimate noise = estimate_impulse(u, respond(Eigen::VectorXd::Zero(kMaxLag + 1), u, 1.0, 4), kMaxLag);
  EXPECT_LT(noise.delay, kMaxLag / 2) << "output independent of the input";
  const ImpulseEstimate early = estimate_impulse(u, respond(delayed_response(7), u, 0.01, 3), kMaxLag);
  EXPECT_TRUE(early.delay_found);
  EXPECT_EQ(early.delay, 7);
}

TEST(ImpulseEstimateTest, TheSurveySaysHowItsDelayWasFound) {
  const Eigen::VectorXd u = dsp::uniform_noise(kSamples, 1.0, 9);
  const DataSurvey found = survey_data(u, respond(delayed_response(3), u, 0.01, 5), kMaxLag);
  EXPECT_TRUE(found.delay_found);
  EXPECT_EQ(found.delay, 3);
  EXPECT_NE(delay_finding(found).find("first significant tap (lag 3"), std::string::npos) << delay_finding(found);
  const DataSurvey none = survey_data(u, respond(delayed_response(150), u, 0.01, 5), kMaxLag);
  EXPECT_FALSE(none.delay_found);
  EXPECT_EQ(none.delay, 0);
  EXPECT_NE(delay_finding(none).find("no dead time is assumed: nk = 0"), std::string::npos) << delay_finding(none);
  EXPECT_EQ(data_survey_to_json(none)["delay_found"], false);
}

}  // namespace
}  // namespace panelbass::models

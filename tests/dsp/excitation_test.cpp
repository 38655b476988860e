// Excitation signals against their definitions: determinism, ranges, moments, exact periodicity,
// line content (by FFT), and instantaneous frequency.
#include "dsp/excitation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <set>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/FFT>
#include <vector>

#include "dsp/random.h"
#include "tests/support/expect_error.h"

namespace panelbass::dsp {
namespace {

using std::numbers::pi;

std::vector<std::complex<double>> fft_of(const Eigen::VectorXd& x) {
  std::vector<double> in(x.data(), x.data() + x.size());
  std::vector<std::complex<double>> out;
  Eigen::FFT<double> fft;
  fft.fwd(out, in);
  return out;
}

bool bit_identical(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return a.size() == b.size() && std::equal(a.data(), a.data() + a.size(), b.data());
}

using testing_support::expect_invalid;

// ---- noise ----------------------------------------------------------------------------------

TEST(ExcitationNoiseTest, UniformNoiseIsRngUniformPerSample) {
  const Eigen::VectorXd x = uniform_noise(1000, 0.8, 99);
  Rng rng(99);
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    ASSERT_EQ(x[i], rng.uniform(-0.8, 0.8));
  }
}

TEST(ExcitationNoiseTest, UniformNoiseDeterministicPerSeed) {
  EXPECT_TRUE(bit_identical(uniform_noise(5000, 1.0, 4), uniform_noise(5000, 1.0, 4)));
  EXPECT_FALSE(bit_identical(uniform_noise(5000, 1.0, 4), uniform_noise(5000, 1.0, 5)));
}

TEST(ExcitationNoiseTest, UniformNoiseRangeAndVariance) {
  // U[−A, A]: mean 0, variance A²/3; the standard error of the mean square is
  // A² sqrt((1/5 − 1/9)/n) = 9.4e-4 A² for n = 100000. Bounds are 5 standard errors.
  const double a = 0.5;
  const Eigen::VectorXd x = uniform_noise(100000, a, 21);
  EXPECT_LE(x.maxCoeff(), a);
  EXPECT_GE(x.minCoeff(), -a);
  EXPECT_NEAR(x.mean(), 0.0, 5 * a * std::sqrt(1.0 / 3.0 / 100000));
  EXPECT_NEAR(x.squaredNorm() / 100000, a * a / 3.0, 5 * 9.4e-4 * a * a);
}

TEST(ExcitationNoiseTest, GaussianNoiseTruncatedAtAmplitude) {
  // N(0, (A/3)²) truncated to ±3σ: variance σ²(1 − 6φ(3)/(2Φ(3) − 1)) (truncated-normal closed
  // form). Standard error of the variance ≈ σ² sqrt(2/n) = 4.5e-3 σ² for n = 100000.
  const double a = 0.9;
  const double sigma = a / 3.0;
  const Eigen::VectorXd x = gaussian_noise(100000, a, 8);
  EXPECT_LE(x.cwiseAbs().maxCoeff(), a);
  const double phi3 = std::exp(-4.5) / std::sqrt(2.0 * pi);
  const double mass = std::erf(3.0 / std::sqrt(2.0));  // 2Φ(3) − 1
  const double expected_variance = sigma * sigma * (1.0 - 6.0 * phi3 / mass);
  EXPECT_NEAR(x.mean(), 0.0, 5 * sigma / std::sqrt(100000.0));
  EXPECT_NEAR(x.squaredNorm() / 100000, expected_variance, 5 * 4.5e-3 * sigma * sigma);
  // Redrawing, not clipping: no sample sits exactly at the bound.
  EXPECT_EQ((x.cwiseAbs().array() == a).count(), 0);
}

TEST(ExcitationNoiseTest, GaussianNoiseDeterministicPerSeed) {
  EXPECT_TRUE(bit_identical(gaussian_noise(5000, 1.0, 4), gaussian_noise(5000, 1.0, 4)));
  EXPECT_FALSE(bit_identical(gaussian_noise(5000, 1.0, 4), gaussian_noise(5000, 1.0, 5)));
}

TEST(ExcitationNoiseTest, InvalidArgumentsNameTheParameter) {
  const double nan = std::nan("");
  for (const double bad : {0.0, -1.0, nan, std::numeric_limits<double>::infinity()}) {
    expect_invalid([&] { uniform_noise(10, bad, 1); }, "amplitude");
    expect_invalid([&] { gaussian_noise(10, bad, 1); }, "amplitude");
  }
  expect_invalid([] { uniform_noise(0, 1.0, 1); }, "samples");
  expect_invalid([] { gaussian_noise(0, 1.0, 1); }, "samples");
}

// ---- multisine ------------------------------------------------------------------------------

MultisineSpec small_spec() {
  MultisineSpec spec;
  spec.period = 1024;
  spec.periods = 3;
  spec.fs = 3000.0;
  spec.f_min = 50.0;
  spec.f_max = 1200.0;
  spec.amplitude = 0.7;
  spec.seed = 12;
  return spec;
}

// Energy on bins outside `lines` (0 < k < N/2) relative to the energy on them.
double relative_energy_outside(const std::vector<std::complex<double>>& bins,
                               const std::vector<std::size_t>& lines) {
  const std::set<std::size_t> excited(lines.begin(), lines.end());
  double inside = 0.0;
  double outside = 0.0;
  for (std::size_t k = 0; k <= bins.size() / 2; ++k) {
    (excited.count(k) ? inside : outside) += std::norm(bins[k]);
  }
  return outside / inside;
}

TEST(ExcitationMultisineTest, ExactlyPeriodicWithExactPeak) {
  const MultisineSpec spec = small_spec();
  const Multisine m = multisine(spec);
  ASSERT_EQ(m.signal.size(), 3 * 1024);
  const Eigen::VectorXd first = m.signal.head(1024);
  EXPECT_TRUE(bit_identical(first, m.signal.segment(1024, 1024)));
  EXPECT_TRUE(bit_identical(first, m.signal.segment(2048, 1024)));
  EXPECT_EQ(m.signal.cwiseAbs().maxCoeff(), spec.amplitude);
}

TEST(ExcitationMultisineTest, AllLinesInBandWithEqualMagnitudes) {
  const MultisineSpec spec = small_spec();
  const Multisine m = multisine(spec);
  // Bins k with 50 <= k·3000/1024 <= 1200: k = ceil(17.07) = 18 .. floor(409.6) = 409.
  std::vector<std::size_t> expected;
  for (std::size_t k = 18; k <= 409; ++k) {
    expected.push_back(k);
  }
  EXPECT_EQ(m.lines, expected);
  EXPECT_TRUE(m.detection_lines.empty());

  const auto bins = fft_of(m.signal.head(1024));
  EXPECT_LT(relative_energy_outside(bins, m.lines), 1e-20);
  const double reference = std::abs(bins[m.lines.front()]);
  for (const std::size_t k : m.lines) {
    EXPECT_NEAR(std::abs(bins[k]) / reference, 1.0, 1e-9) << "line " << k;
  }
}

TEST(ExcitationMultisineTest, DeterministicPerSeed) {
  MultisineSpec spec = small_spec();
  const Multisine a = multisine(spec);
  const Multisine b = multisine(spec);
  EXPECT_TRUE(bit_identical(a.signal, b.signal));
  spec.seed = 13;
  EXPECT_FALSE(bit_identical(a.signal, multisine(spec).signal));
}

TEST(ExcitationMultisineTest, OddLinesOnly) {
  MultisineSpec spec = small_spec();
  spec.lines = MultisineLines::odd;
  const Multisine m = multisine(spec);
  ASSERT_FALSE(m.lines.empty());
  for (const std::size_t k : m.lines) {
    EXPECT_EQ(k % 2, 1u);
  }
  // Odd bins 19..409: (409 − 19)/2 + 1 = 196 lines.
  EXPECT_EQ(m.lines.size(), 196u);
  const auto bins = fft_of(m.signal.head(1024));
  EXPECT_LT(relative_energy_outside(bins, m.lines), 1e-20);
}

TEST(ExcitationMultisineTest, RandomOddLeavesOneLinePerGroup) {
  MultisineSpec spec = small_spec();
  spec.lines = MultisineLines::random_odd;
  spec.group = 4;
  const Multisine m = multisine(spec);
  // The odd lines in the band, 19..409 (196 of them = 49 complete groups of 4).
  std::vector<std::size_t> odd;
  for (std::size_t k = 19; k <= 409; k += 2) {
    odd.push_back(k);
  }
  ASSERT_EQ(m.detection_lines.size(), 49u);
  ASSERT_EQ(m.lines.size() + m.detection_lines.size(), odd.size());
  const std::set<std::size_t> excited(m.lines.begin(), m.lines.end());
  const std::set<std::size_t> detection(m.detection_lines.begin(), m.detection_lines.end());
  for (std::size_t g = 0; g < odd.size(); g += 4) {
    int missing = 0;
    for (std::size_t i = g; i < g + 4; ++i) {
      EXPECT_NE(excited.count(odd[i]), detection.count(odd[i])) << "line " << odd[i];
      missing += detection.count(odd[i]) ? 1 : 0;
    }
    EXPECT_EQ(missing, 1) << "group starting at line " << odd[g];
  }
  EXPECT_TRUE(std::is_sorted(m.lines.begin(), m.lines.end()));
  EXPECT_TRUE(std::is_sorted(m.detection_lines.begin(), m.detection_lines.end()));
  const auto bins = fft_of(m.signal.head(1024));
  EXPECT_LT(relative_energy_outside(bins, m.lines), 1e-20);

  // The left-out lines are chosen at random: another seed picks others.
  spec.seed = 77;
  EXPECT_NE(multisine(spec).detection_lines, m.detection_lines);
}

TEST(ExcitationMultisineTest, BandMayReachNyquistButNotInclude) {
  MultisineSpec spec = small_spec();
  spec.period = 16;
  spec.periods = 1;
  spec.f_min = 0.0;
  spec.f_max = 1500.0;  // fs/2
  const Multisine m = multisine(spec);
  const std::vector<std::size_t> expected{1, 2, 3, 4, 5, 6, 7};  // neither DC nor bin 8
  EXPECT_EQ(m.lines, expected);
}

TEST(ExcitationMultisineTest, InvalidSpecsThrow) {
  MultisineSpec spec = small_spec();
  spec.f_max = 1600.0;
  expect_invalid([&] { multisine(spec); }, "f_max");
  spec = small_spec();
  spec.f_min = 1300.0;
  expect_invalid([&] { multisine(spec); }, "f_max");
  spec = small_spec();
  spec.f_min = 1000.0;  // between bins 341 (999.0 Hz) and 342 (1001.95 Hz): an empty band
  spec.f_max = 1001.0;
  EXPECT_THROW(multisine(spec), std::invalid_argument);
  spec = small_spec();
  spec.period = 3;
  expect_invalid([&] { multisine(spec); }, "period");
  spec = small_spec();
  spec.amplitude = 0.0;
  expect_invalid([&] { multisine(spec); }, "amplitude");
}

// ---- sweep and sines ------------------------------------------------------------------------

// Linearly interpolated times (s) at which x changes sign.
std::vector<double> zero_crossings(const Eigen::VectorXd& x, double fs) {
  std::vector<double> t;
  for (Eigen::Index i = 0; i + 1 < x.size(); ++i) {
    if ((x[i] <= 0.0 && x[i + 1] > 0.0) || (x[i] >= 0.0 && x[i + 1] < 0.0)) {
      t.push_back((static_cast<double>(i) + x[i] / (x[i] - x[i + 1])) / fs);
    }
  }
  return t;
}

TEST(ExcitationSweepTest, InstantaneousFrequencyFollowsExponential) {
  // f(t) = f1 e^{t/L}, L = T / ln(f2/f1): each half period between crossings at t_a, t_b has
  // mean frequency 1/(2(t_b − t_a)); compare with f at the midpoint.
  const double fs = 8000.0;
  const double f1 = 20.0;
  const double f2 = 500.0;
  const std::size_t samples = 16000;
  const double amplitude = 0.6;
  const Eigen::VectorXd x = log_sweep(samples, fs, f1, f2, amplitude);
  ASSERT_EQ(x.size(), static_cast<Eigen::Index>(samples));
  EXPECT_LE(x.cwiseAbs().maxCoeff(), amplitude);
  EXPECT_EQ(x[0], 0.0);

  const std::vector<double> t = zero_crossings(x, fs);
  ASSERT_GT(t.size(), 100u);
  const double duration = static_cast<double>(samples) / fs;
  const double rate = duration / std::log(f2 / f1);
  for (std::size_t i = 1; i < t.size(); ++i) {
    const double measured = 0.5 / (t[i] - t[i - 1]);
    const double expected = f1 * std::exp(0.5 * (t[i] + t[i - 1]) / rate);
    EXPECT_NEAR(measured / expected, 1.0, 0.01) << "crossing " << i;
  }
  // At the ends: the first half period (the sweep starts with a crossing at t = 0) and the last
  // four half periods.
  EXPECT_EQ(t[0], 0.0);
  EXPECT_NEAR(0.5 / (t[1] - t[0]) / f1, 1.0, 0.03);
  const std::size_t n = t.size();
  EXPECT_NEAR(2.0 / (t[n - 1] - t[n - 5]) / f2, 1.0, 0.03);
}

TEST(ExcitationSweepTest, InvalidArgumentsThrow) {
  expect_invalid([] { log_sweep(100, 8000.0, 0.0, 100.0, 1.0); }, "f_start");
  expect_invalid([] { log_sweep(100, 8000.0, 20.0, 4000.0, 1.0); }, "f_stop");
  expect_invalid([] { log_sweep(100, 8000.0, 20.0, 200.0, -1.0); }, "amplitude");
  expect_invalid([] { log_sweep(0, 8000.0, 20.0, 200.0, 1.0); }, "samples");
  expect_invalid([] { log_sweep(100, 0.0, 20.0, 200.0, 1.0); }, "fs");
}

TEST(ExcitationSineTest, MatchesClosedForm) {
  const Eigen::VectorXd x = sine(500, 3000.0, 123.0, 0.4);
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    ASSERT_NEAR(x[i], 0.4 * std::sin(2.0 * pi * 123.0 * static_cast<double>(i) / 3000.0), 1e-15);
  }
  expect_invalid([] { sine(10, 3000.0, 1500.0, 1.0); }, "frequency");
}

TEST(ExcitationSteppedSineTest, StepsSnappedToBinsWithContinuousPhase) {
  SteppedSineSpec spec;
  spec.fs = 3000.0;
  spec.amplitude = 0.5;
  spec.settle = 200;
  spec.measure = 1000;  // bins every 3 Hz
  spec.frequencies = {100.0, 333.3, 1000.0, 0.5, 1499.0};
  const SteppedSine s = stepped_sine(spec);
  ASSERT_EQ(s.steps.size(), 5u);
  ASSERT_EQ(s.signal.size(), 5 * 1200);

  // Nearest bin j = round(f·measure/fs), kept within 1 .. measure/2 − 1.
  const std::vector<double> expected_bins{33, 111, 333, 1, 499};
  double phase = 0.0;  // the independent reference: a running phase sum
  for (std::size_t i = 0; i < s.steps.size(); ++i) {
    const SineStep& step = s.steps[i];
    EXPECT_DOUBLE_EQ(step.frequency, expected_bins[i] * 3.0);
    EXPECT_EQ(step.measure_start, i * 1200 + 200);
    EXPECT_EQ(step.measure_length, 1000u);
    // The step's first sample continues the previous step's phase.
    EXPECT_NEAR(s.signal[static_cast<Eigen::Index>(i * 1200)], 0.5 * std::sin(phase), 1e-9)
        << "step " << i;
    phase += 2.0 * pi * step.frequency / spec.fs * 1200.0;

    // Whole periods in the measured part: all energy on bin j.
    const auto bins = fft_of(
        s.signal.segment(static_cast<Eigen::Index>(step.measure_start), 1000));
    const auto j = static_cast<std::size_t>(expected_bins[i]);
    EXPECT_LT(relative_energy_outside(bins, {j}), 1e-20) << "step " << i;
    EXPECT_NEAR(std::abs(bins[j]), 0.5 * 1000 / 2.0, 1e-9);
  }

  // No jump larger than a sine's largest one-sample change at the fastest frequency.
  const double largest_step = 2.0 * 0.5 * std::sin(pi * 1497.0 / 3000.0);
  for (Eigen::Index n = 0; n + 1 < s.signal.size(); ++n) {
    ASSERT_LE(std::abs(s.signal[n + 1] - s.signal[n]), largest_step + 1e-12) << "sample " << n;
  }
  // And at each boundary, no larger than the preceding step's own one-sample change allows.
  for (std::size_t i = 1; i < s.steps.size(); ++i) {
    const auto b = static_cast<Eigen::Index>(i * 1200);
    const double f = std::max(s.steps[i - 1].frequency, s.steps[i].frequency);
    EXPECT_LE(std::abs(s.signal[b] - s.signal[b - 1]), 2.0 * 0.5 * std::sin(pi * f / 3000.0) + 1e-12);
  }
}

TEST(ExcitationSteppedSineTest, InvalidArgumentsThrow) {
  SteppedSineSpec spec;
  EXPECT_THROW(stepped_sine(spec), std::invalid_argument);  // no frequencies
  spec.frequencies = {100.0, 2000.0};
  expect_invalid([&] { stepped_sine(spec); }, "frequency");
  spec.frequencies = {100.0};
  spec.amplitude = std::numeric_limits<double>::infinity();
  expect_invalid([&] { stepped_sine(spec); }, "amplitude");
}

}  // namespace
}  // namespace panelbass::dsp

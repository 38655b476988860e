// The low-latency resampler against computations that do not share its code: the designed taps'
// magnitude response evaluated here by the DTFT, Σ h[k] e^{−iωk} (pass-band ripple and stop-band
// rejection as specified); the streaming polyphase bank against the plain definition of rational
// resampling, the zero-stuffed input convolved with the whole prototype, y[m] = L Σ_k h[k] x↑[mM − k];
// and the minimum-phase property as the delay at low frequencies well under a linear-phase filter's.
#include "dsp/polyphase_resampler.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>
#include <span>
#include <stdexcept>
#include <vector>

#include "dsp/random.h"
#include "tests/support/expect_error.h"

namespace panelbass::dsp {
namespace {

const LowLatencySpec kSpec{0.8, 80.0};

/// |H(f)| of `taps` sampled at `fs`, by the DTFT.
double magnitude(const std::vector<double>& taps, double fs, double f) {
  std::complex<double> h = 0.0;
  const double w = 2.0 * std::numbers::pi * f / fs;
  for (std::size_t k = 0; k < taps.size(); ++k) h += taps[k] * std::polar(1.0, -w * static_cast<double>(k));
  return std::abs(h);
}

struct Direction {
  double from, to;
};

class Designs : public ::testing::TestWithParam<Direction> {};

TEST_P(Designs, MeetTheirRippleAndRejection) {
  const auto [from, to] = GetParam();
  const LowLatencyFilter f = design_low_latency_filter(from, to, kSpec);
  EXPECT_DOUBLE_EQ(f.pass_hz, 1200.0);
  EXPECT_DOUBLE_EQ(f.stop_hz, 1800.0);
  EXPECT_EQ(f.taps.size() % static_cast<std::size_t>(f.up), 0u);
  EXPECT_DOUBLE_EQ(static_cast<double>(f.up) / f.down, to / from);
  double worst_pass = 0.0, worst_stop = -1000.0;
  for (double hz = 0.0; hz <= f.pass_hz; hz += 10.0) worst_pass = std::max(worst_pass, std::abs(20.0 * std::log10(magnitude(f.taps, f.prototype_rate, hz))));
  // The stop band: densely near its edge, coarsely on to the prototype's Nyquist frequency.
  for (double hz = f.stop_hz; hz < f.prototype_rate / 2; hz += hz < f.stop_hz + 3000.0 ? 3.0 : f.prototype_rate / 6000.0) {
    worst_stop = std::max(worst_stop, 20.0 * std::log10(magnitude(f.taps, f.prototype_rate, hz)));
  }
  std::printf("[ design   ] %.0f -> %.0f Hz: %zu taps at %.0f Hz, pass-band ripple %.5f dB (bound %.5f), "
              "stop band %.1f dB, delay %.3f ms\n",
              from, to, f.taps.size(), f.prototype_rate, worst_pass, f.ripple_db, worst_stop, 1e3 * f.delay_s);
  EXPECT_LT(worst_pass, f.ripple_db);
  EXPECT_LT(worst_stop, -kSpec.attenuation_db);
  // Minimum phase: the centre of mass well before the linear-phase filter's (N − 1)/2.
  const double linear_delay = 0.5 * static_cast<double>(f.taps.size() - 1) / f.prototype_rate;
  EXPECT_LT(f.delay_s, 0.25 * linear_delay);
  EXPECT_GT(f.delay_s, 0.0);
}

TEST_P(Designs, PolyphaseBankIsTheZeroStuffedConvolution) {
  const auto [from, to] = GetParam();
  PolyphaseResampler resampler(from, to, 2, 300, kSpec);
  const LowLatencyFilter& f = resampler.filter();
  Rng rng(11);
  std::vector<double> a(4000), b(a.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    a[k] = rng.uniform(-1.0, 1.0);
    b[k] = rng.uniform(-1.0, 1.0);
  }
  std::vector<double> ya, yb;
  const int sizes[] = {1, 13, 300, 64, 7, 127, 250};
  for (std::size_t pos = 0, i = 0; pos < a.size(); ++i) {
    const std::size_t n = std::min<std::size_t>(static_cast<std::size_t>(sizes[i % 7]), a.size() - pos);
    const std::span<const double> in[2] = {{a.data() + pos, n}, {b.data() + pos, n}};
    const std::size_t got = resampler.process(in);
    ASSERT_LE(got, resampler.max_output());
    ya.insert(ya.end(), resampler.output(0).begin(), resampler.output(0).begin() + static_cast<long>(got));
    yb.insert(yb.end(), resampler.output(1).begin(), resampler.output(1).begin() + static_cast<long>(got));
    pos += n;
  }
  // Every output m whose last input ⌊mM/L⌋ has arrived: mM ≤ n·L − 1 for n inputs.
  const auto L = static_cast<long>(f.up), M = static_cast<long>(f.down);
  const auto expected_count = static_cast<std::size_t>((static_cast<long>(a.size()) * L - 1) / M + 1);
  ASSERT_EQ(ya.size(), expected_count);
  double worst = 0.0;
  for (std::size_t m = 0; m < ya.size(); ++m) {
    double ea = 0.0, eb = 0.0;
    for (long k = 0; k < static_cast<long>(f.taps.size()); ++k) {
      const long j = static_cast<long>(m) * M - k;  // index into the zero-stuffed input
      if (j < 0) break;
      if (j % L != 0) continue;
      ea += static_cast<double>(L) * f.taps[static_cast<std::size_t>(k)] * a[static_cast<std::size_t>(j / L)];
      eb += static_cast<double>(L) * f.taps[static_cast<std::size_t>(k)] * b[static_cast<std::size_t>(j / L)];
    }
    worst = std::max({worst, std::abs(ya[m] - ea), std::abs(yb[m] - eb)});
  }
  EXPECT_LT(worst, 1e-12);
  // Reset: the same input gives the same output again.
  resampler.reset();
  const std::span<const double> first[2] = {{a.data(), 300}, {b.data(), 300}};
  const std::size_t got = resampler.process(first);
  ASSERT_GT(got, 0u);
  for (std::size_t m = 0; m < got; ++m) EXPECT_EQ(resampler.output(0)[m], ya[m]) << m;
}

INSTANTIATE_TEST_SUITE_P(LowLatency, Designs,
                         ::testing::Values(Direction{48000.0, 3000.0}, Direction{3000.0, 48000.0},
                                           Direction{44100.0, 3000.0}, Direction{3000.0, 44100.0}),
                         [](const ::testing::TestParamInfo<Direction>& info) {
                           return std::to_string(static_cast<int>(info.param.from)) + "to" +
                                  std::to_string(static_cast<int>(info.param.to));
                         });

TEST(LowLatencyResampler, BadInputIsNamed) {
  using testing_support::one_line_error;
  EXPECT_NE(one_line_error<std::invalid_argument>([] { design_low_latency_filter(44100.5, 3000.0, kSpec); }).find("input rate must be a whole number"),
            std::string::npos);
  EXPECT_NE(one_line_error<std::invalid_argument>([] { design_low_latency_filter(48000.0, 0.0, kSpec); }).find("output rate"),
            std::string::npos);
  EXPECT_NE(one_line_error<std::invalid_argument>([] { design_low_latency_filter(48001.0, 3000.0, kSpec); }).find("3000/48001"),
            std::string::npos);
  EXPECT_NE(one_line_error<std::invalid_argument>([] { design_low_latency_filter(48000.0, 3000.0, {1.0, 80.0}); }).find("passband"),
            std::string::npos);
  EXPECT_NE(one_line_error<std::invalid_argument>([] { design_low_latency_filter(48000.0, 3000.0, {0.8, 10.0}); }).find("attenuation_db"),
            std::string::npos);
  EXPECT_NE(one_line_error<std::invalid_argument>([] { PolyphaseResampler r(48000.0, 3000.0, 0, 64, kSpec); }).find("channels"),
            std::string::npos);
}

}  // namespace
}  // namespace panelbass::dsp

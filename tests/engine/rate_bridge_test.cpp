// The rate bridge against expectations computed here, not by the bridge: libsamplerate's converters
// are time-aligned, so a sine converted to another rate must equal the same sine evaluated at the new
// rate's sample times (sin(2π f m / fs_new)); the bridge's only delay is its FIFO priming, so an
// impulse in must come out with its centre of mass exactly latency().total_samples later; and a FIFO
// that never runs dry must leave no underrun, whatever the period sizes. The low-latency converters
// (the default) are minimum-phase, so a sine comes out scaled by |H(f)| and shifted by its phase: they
// are held to their specification instead — the impulse's centre of mass at the reported latency
// (≤ 2 ms), pass-band sines at unit gain within the stated ripple, an alias or image tone below the
// stated rejection — measured by least-squares sine fits (dsp/sine_fit.h), independent of the design.
#include "engine/rate_bridge.h"

#include <gtest/gtest.h>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "dsp/sine_fit.h"

namespace panelbass::engine {
namespace {

constexpr double kModelRate = 3000.0;

/// Period sizes that are not multiples of 16 or 14.7, cycled through.
const std::vector<int> kOddPeriods = {1, 13, 64, 127, 250, 7, 64, 199, 33, 256};

/// `signal` through `resampler` in chunks of the sizes in kOddPeriods (capped at max_input); the output.
std::vector<double> convert(StreamingResampler& resampler, const std::vector<double>& signal, int max_input) {
  std::vector<double> out;
  std::size_t pos = 0;
  for (std::size_t i = 0; pos < signal.size(); ++i) {
    const std::size_t n = std::min<std::size_t>(static_cast<std::size_t>(std::min(kOddPeriods[i % kOddPeriods.size()], max_input)),
                                                signal.size() - pos);
    const std::span<const double> chunk(signal.data() + pos, n);
    const std::size_t got = resampler.process(std::span<const std::span<const double>>(&chunk, 1));
    const std::span<const double> y = resampler.output(0).first(got);
    out.insert(out.end(), y.begin(), y.end());
    pos += n;
  }
  return out;
}

std::vector<double> sine(double f, double fs, std::size_t n, double amplitude) {
  std::vector<double> x(n);
  for (std::size_t k = 0; k < n; ++k) x[k] = amplitude * std::sin(2.0 * std::numbers::pi * f * static_cast<double>(k) / fs);
  return x;
}

/// Largest |y[k] − expected(k)| for k in [from, y.size()).
template <class Expected>
double max_error(const std::vector<double>& y, std::size_t from, Expected&& expected) {
  double worst = 0.0;
  for (std::size_t k = from; k < y.size(); ++k) worst = std::max(worst, std::abs(y[k] - expected(k)));
  return worst;
}

/// `x` through the bridge in kOddPeriods-sized periods, the identity in place of the chain.
std::vector<double> through_bridge(RateBridge& bridge, const std::vector<double>& x) {
  std::vector<double> y(x.size(), 0.0);
  for (std::size_t pos = 0, i = 0; pos < x.size(); ++i) {
    const std::size_t n = std::min<std::size_t>(static_cast<std::size_t>(std::min(kOddPeriods[i % kOddPeriods.size()], 256)), x.size() - pos);
    const std::span<const double> in(x.data() + pos, n);
    bridge.process(std::span<const std::span<const double>>(&in, 1), std::span<double>(y.data() + pos, n),
                   [](std::span<const std::span<const double>> model_in, std::span<double> model_out) {
                     std::copy(model_in[0].begin(), model_in[0].end(), model_out.begin());
                   });
    pos += n;
  }
  return y;
}

/// The bridge's response to a unit impulse at sample `at` of `length`: its area Σ y (the DC gain), centre
/// of mass Σ k·y[k] / Σ y[k] and the position of its largest sample, both counted from `at`.
struct ImpulseFigures {
  double area = 0.0, centre = 0.0;
  int peak = 0;
};

ImpulseFigures impulse_response(RateBridge& bridge, std::size_t length, std::size_t at) {
  std::vector<double> x(length, 0.0);
  x[at] = 1.0;
  const std::vector<double> y = through_bridge(bridge, x);
  double area = 0.0, moment = 0.0;
  std::size_t peak = 0;
  for (std::size_t k = 0; k < y.size(); ++k) {
    area += y[k];
    moment += static_cast<double>(k) * y[k];
    if (std::abs(y[k]) > std::abs(y[peak])) peak = k;
  }
  return {area, moment / area - static_cast<double>(at), static_cast<int>(peak) - static_cast<int>(at)};
}

// Error bound for a 0.8-amplitude sine well inside the pass band (437 Hz of 1200): libsamplerate's
// fastest converter claims 97 dB SNR; single-precision samples, pass-band ripple and the tails of a
// truncated sinc stay under 1e-4 (−80 dB re 1) after the start-up transient (1.3e-5 measured at worst).
constexpr double kSineTolerance = 1e-4;
constexpr double kF = 437.0;
constexpr double kAmplitude = 0.8;

class AtDeviceRate : public ::testing::TestWithParam<double> {};

TEST_P(AtDeviceRate, DecimatedSineIsTheSineAtTheModelRate) {
  const double fs = GetParam();
  StreamingResampler decimator(Hertz{fs}, Hertz{kModelRate}, 1, 256, ResampleQuality::fastest);
  const std::vector<double> x = sine(kF, fs, static_cast<std::size_t>(fs), kAmplitude);  // 1 s
  const std::vector<double> y = convert(decimator, x, 256);
  // Time-aligned: model sample m is at t = m / 3000 s. Half a second of output at least.
  ASSERT_GT(y.size(), 1500u);
  const double err = max_error(y, 100, [](std::size_t m) {
    return kAmplitude * std::sin(2.0 * std::numbers::pi * kF * static_cast<double>(m) / kModelRate);
  });
  std::printf("[ sine     ] %.0f Hz -> 3000 Hz: max error %.2e\n", fs, err);
  EXPECT_LT(err, kSineTolerance) << fs << " Hz -> 3000 Hz";
  EXPECT_EQ(decimator.errors(), 0u);
}

TEST_P(AtDeviceRate, InterpolatedSineIsTheSineAtTheDeviceRate) {
  const double fs = GetParam();
  StreamingResampler interpolator(Hertz{kModelRate}, Hertz{fs}, 1, 64, ResampleQuality::fastest);
  const std::vector<double> x = sine(kF, kModelRate, 3000, kAmplitude);
  const std::vector<double> y = convert(interpolator, x, 64);
  ASSERT_GT(y.size(), static_cast<std::size_t>(fs / 2));
  const double err = max_error(y, static_cast<std::size_t>(fs / 30), [fs](std::size_t j) {
    return kAmplitude * std::sin(2.0 * std::numbers::pi * kF * static_cast<double>(j) / fs);
  });
  std::printf("[ sine     ] 3000 Hz -> %.0f Hz: max error %.2e\n", fs, err);
  EXPECT_LT(err, kSineTolerance) << "3000 Hz -> " << fs << " Hz";
}

TEST_P(AtDeviceRate, ModelRateSineSurvivesUpAndDown) {
  const double fs = GetParam();
  StreamingResampler up(Hertz{kModelRate}, Hertz{fs}, 1, 256, ResampleQuality::fastest);
  StreamingResampler down(Hertz{fs}, Hertz{kModelRate}, 1, 256 * 17, ResampleQuality::fastest);
  const std::vector<double> x = sine(kF, kModelRate, 3000, kAmplitude);
  const std::vector<double> device = convert(up, x, 256);
  const std::vector<double> back = convert(down, device, 256 * 17);
  ASSERT_GT(back.size(), 1400u);
  const double err = max_error(back, 100, [&x](std::size_t m) { return x[m]; });
  std::printf("[ sine     ] 3000 -> %.0f -> 3000 Hz: max error %.2e\n", fs, err);
  EXPECT_LT(err, kSineTolerance) << "3000 -> " << fs << " -> 3000 Hz";
}

TEST_P(AtDeviceRate, SineThroughTheBridgeComesOutDelayedByTheReportedLatency) {
  const double fs = GetParam();
  RateBridgeOptions options;
  options.device_rate = Hertz{fs};
  options.max_period = Samples{256};
  options.quality = ResampleQuality::fastest;  // time-aligned: the sine itself, only later
  RateBridge bridge(options);
  const int latency = bridge.latency().total_samples;
  const std::vector<double> x = sine(kF, fs, static_cast<std::size_t>(fs), kAmplitude);
  const std::vector<double> y = through_bridge(bridge, x);
  // Silence while the FIFO's priming comes out, then the sine, late by exactly the latency.
  for (int k = 0; k < latency; ++k) ASSERT_EQ(y[static_cast<std::size_t>(k)], 0.0) << k;
  const double err = max_error(y, static_cast<std::size_t>(latency) + static_cast<std::size_t>(fs / 30), [&](std::size_t n) {
    return kAmplitude * std::sin(2.0 * std::numbers::pi * kF * (static_cast<double>(n) - latency) / fs);
  });
  std::printf("[ sine     ] bridge %.0f -> 3000 -> %.0f Hz, %d samples late: max error %.2e\n", fs, fs, latency, err);
  EXPECT_LT(err, 2 * kSineTolerance) << fs << " -> 3000 -> " << fs << " Hz";
  EXPECT_EQ(bridge.underrun_frames(), 0u);
  EXPECT_EQ(bridge.overflow_frames(), 0u);
  EXPECT_EQ(bridge.converter_errors(), 0u);
}

TEST_P(AtDeviceRate, ImpulseComesOutAfterExactlyTheReportedLatency) {
  const double fs = GetParam();
  RateBridgeOptions options;
  options.device_rate = Hertz{fs};
  options.max_period = Samples{256};
  options.quality = ResampleQuality::fastest;
  RateBridge bridge(options);
  const RateBridgeLatency latency = bridge.latency();
  // Off the model-rate grid on purpose (5003 is no multiple of 16 or of 14.7).
  constexpr std::size_t kAt = 5003;
  // Centre of mass: both converters are linear-phase, so it sits at the impulse plus the delay; the
  // area is the DC gain, 1.
  const ImpulseFigures h = impulse_response(bridge, 20000, kAt);
  std::printf("[ latency  ] %.0f Hz <-> 3000 Hz: reported %d device samples (%.3f ms; decimator lag %.1f, "
              "interpolator lag %.1f), impulse centre of mass at +%.3f, peak at +%d\n",
              fs, latency.total_samples, latency.total_ms, latency.decimator_samples, latency.interpolator_samples,
              h.centre, h.peak);
  EXPECT_NEAR(h.area, 1.0, 1e-3);
  EXPECT_NEAR(h.centre, latency.total_samples, 0.05);
  EXPECT_LE(std::abs(h.peak - latency.total_samples), 1);
  EXPECT_NEAR(latency.total_ms, 1e3 * latency.total_samples / fs, 1e-9);
  // The priming covers both converters' look-ahead (and no more than both plus a model sample and the margin).
  EXPECT_GE(latency.total_samples, std::max(latency.decimator_samples, latency.interpolator_samples));
  EXPECT_LE(latency.total_samples, latency.decimator_samples + latency.interpolator_samples + fs / kModelRate + 3);
  EXPECT_EQ(bridge.underrun_frames(), 0u);
}

/// The amplitude of the least-squares sine at `f` in `y` from sample `from` on (rate fs).
double amplitude_at(const std::vector<double>& y, std::size_t from, double fs, double f) {
  const Eigen::VectorXd tail = Eigen::Map<const Eigen::VectorXd>(y.data() + from, static_cast<Eigen::Index>(y.size() - from));
  const Eigen::Vector3d c = dsp::fit_sine(tail, fs, f).coefficients;
  return std::hypot(c[0], c[1]);
}

RateBridge low_latency_bridge(double fs) {
  RateBridgeOptions options;
  options.device_rate = Hertz{fs};
  options.max_period = Samples{256};
  EXPECT_EQ(options.quality, ResampleQuality::low_latency);  // the default
  return RateBridge(options);
}

// The converters' specification (engine/rate_bridge.h's kLowLatencySpec): ±δ in the pass band and
// below δ in the stop band per converter, δ = 10^(−80/20); the truncated minimum-phase taps get twice that.
const double kDelta = 2.0 * std::pow(10.0, -kLowLatencySpec.attenuation_db / 20.0);

TEST_P(AtDeviceRate, LowLatencyImpulseComesOutWithinTwoMilliseconds) {
  const double fs = GetParam();
  RateBridge bridge = low_latency_bridge(fs);
  const RateBridgeLatency latency = bridge.latency();
  constexpr std::size_t kAt = 5003;
  const ImpulseFigures h = impulse_response(bridge, 12000, kAt);
  std::printf("[ latency  ] low-latency %.0f Hz <-> 3000 Hz: reported %.3f ms (%d FIFO + %.2f filter samples), "
              "impulse centre of mass at +%.3f samples (%.3f ms), peak at +%d\n",
              fs, latency.total_ms, latency.fifo_samples, latency.filter_samples, h.centre, 1e3 * h.centre / fs, h.peak);
  EXPECT_NEAR(h.area, 1.0, 1e-3);
  EXPECT_NEAR(h.centre, 1e-3 * latency.total_ms * fs, 0.05);
  EXPECT_EQ(latency.total_samples, static_cast<int>(std::lround(1e-3 * latency.total_ms * fs)));
  EXPECT_LE(latency.total_ms, 2.0);
  EXPECT_EQ(latency.fifo_samples, RateBridgeOptions{}.margin.value);  // nothing held back
  EXPECT_EQ(bridge.underrun_frames(), 0u);
}

TEST_P(AtDeviceRate, LowLatencySinesKeepTheirLevelUpDownAndThroughTheBridge) {
  const double fs = GetParam();
  const std::size_t settle_model = 300, settle_device = static_cast<std::size_t>(fs / 10);  // 0.1 s, far past the filters
  for (const double f : {60.0, 437.0, 1000.0, 1190.0}) {
    StreamingResampler down(Hertz{fs}, Hertz{kModelRate}, 1, 256, ResampleQuality::low_latency);
    StreamingResampler up(Hertz{kModelRate}, Hertz{fs}, 1, 256, ResampleQuality::low_latency);
    const double a_down = amplitude_at(convert(down, sine(f, fs, static_cast<std::size_t>(fs / 2), kAmplitude), 256), settle_model, kModelRate, f);
    const double a_up = amplitude_at(convert(up, sine(f, kModelRate, 1500, kAmplitude), 256), settle_device, fs, f);
    RateBridge bridge = low_latency_bridge(fs);
    const double a_bridge =
        amplitude_at(through_bridge(bridge, sine(f, fs, static_cast<std::size_t>(fs / 2), kAmplitude)), settle_device, fs, f);
    std::printf("[ ripple   ] %.0f Hz at %.0f Hz: gain down %+.5f dB, up %+.5f dB, through the bridge %+.5f dB\n", f, fs,
                20 * std::log10(a_down / kAmplitude), 20 * std::log10(a_up / kAmplitude), 20 * std::log10(a_bridge / kAmplitude));
    EXPECT_NEAR(a_down / kAmplitude, 1.0, kDelta) << f << " Hz down";
    EXPECT_NEAR(a_up / kAmplitude, 1.0, kDelta) << f << " Hz up";
    EXPECT_NEAR(a_bridge / kAmplitude, 1.0, 2 * kDelta) << f << " Hz through the bridge";
  }
}

TEST_P(AtDeviceRate, LowLatencyAliasesAndImagesStayBelowTheRejection) {
  const double fs = GetParam();
  // Decimating: a device tone at f ≥ 1800 Hz folds to 3000·k − f inside the pass band at 3000 Hz.
  for (const double f : {1800.0, 2200.0, 2900.0, 4100.0}) {
    StreamingResampler down(Hertz{fs}, Hertz{kModelRate}, 1, 256, ResampleQuality::low_latency);
    const std::vector<double> y = convert(down, sine(f, fs, static_cast<std::size_t>(fs / 2), kAmplitude), 256);
    const double alias = std::abs(f - kModelRate * std::round(f / kModelRate));
    const double level = amplitude_at(y, 300, kModelRate, alias) / kAmplitude;
    std::printf("[ alias    ] %.0f Hz at %.0f Hz -> %.0f Hz at 3000 Hz: %.1f dB\n", f, fs, alias, 20 * std::log10(level));
    EXPECT_LT(level, kDelta) << f << " Hz";
  }
  // Interpolating: a model-rate tone at f has images at 3000·k ± f on the device side.
  for (const double f : {437.0, 1190.0}) {
    StreamingResampler up(Hertz{kModelRate}, Hertz{fs}, 1, 256, ResampleQuality::low_latency);
    std::vector<double> y = convert(up, sine(f, kModelRate, 1500, kAmplitude), 256);
    // The tone itself taken out first, so that a fit at the image does not pick up its leakage.
    const std::size_t from = static_cast<std::size_t>(fs / 10);
    const Eigen::Vector3d tone =
        dsp::fit_sine(Eigen::Map<const Eigen::VectorXd>(y.data() + from, static_cast<Eigen::Index>(y.size() - from)), fs, f).coefficients;
    for (std::size_t k = from; k < y.size(); ++k) {
      const double w = 2.0 * std::numbers::pi * f * static_cast<double>(k - from) / fs;
      y[k] -= tone[0] * std::cos(w) + tone[1] * std::sin(w) + tone[2];
    }
    for (const double image : {kModelRate - f, kModelRate + f, 2 * kModelRate - f}) {
      const double level = amplitude_at(y, from, fs, image) / kAmplitude;
      std::printf("[ image    ] %.0f Hz at 3000 Hz -> %.0f Hz at %.0f Hz: %.1f dB\n", f, image, fs, 20 * std::log10(level));
      EXPECT_LT(level, kDelta) << f << " Hz, image at " << image << " Hz";
    }
  }
}

INSTANTIATE_TEST_SUITE_P(RateBridge, AtDeviceRate, ::testing::Values(44100.0, 48000.0),
                         [](const ::testing::TestParamInfo<double>& info) {
                           return std::to_string(static_cast<int>(info.param)) + "Hz";
                         });

TEST(RateBridge, EveryPeriodGetsExactlyItsFramesWhateverItsSize) {
  RateBridgeOptions options;
  options.device_rate = Hertz{44100.0};
  options.max_period = Samples{256};
  options.input_channels = 2;
  RateBridge bridge(options);
  std::vector<double> a(256, 0.25), b(256, -0.5), out(256);
  std::size_t model_samples = 0, device_frames = 0;
  for (int i = 0; i < 4000; ++i) {
    const std::size_t n = static_cast<std::size_t>(kOddPeriods[static_cast<std::size_t>(i) % kOddPeriods.size()]);
    const std::span<const double> in[2] = {{a.data(), n}, {b.data(), n}};
    std::fill(out.begin(), out.end(), 9.0);
    bridge.process(std::span<const std::span<const double>>(in, 2), std::span<double>(out.data(), n),
                   [&](std::span<const std::span<const double>> model_in, std::span<double> model_out) {
                     ASSERT_EQ(model_in.size(), 2u);
                     ASSERT_EQ(model_in[1].size(), model_out.size());
                     ASSERT_LE(model_out.size(), bridge.max_model_block());
                     model_samples += model_out.size();
                     for (std::size_t k = 0; k < model_out.size(); ++k) model_out[k] = model_in[0][k] + model_in[1][k];
                   });
    device_frames += n;
    // Every frame of the period was written (9 is not a value the bridge can produce here).
    for (std::size_t k = 0; k < n; ++k) ASSERT_NE(out[k], 9.0) << "period " << i << " frame " << k;
  }
  // The model saw the device frames at its rate, short by the decimator's look-ahead at most.
  const double expected = static_cast<double>(device_frames) * 3000.0 / 44100.0;
  EXPECT_LE(static_cast<double>(model_samples), expected + 1.0);
  EXPECT_GE(static_cast<double>(model_samples), expected - bridge.latency().decimator_samples * 3000.0 / 44100.0 - 1.0);
  // Both channels were decimated: DC 0.25 + (−0.5) = −0.25 at the end.
  EXPECT_NEAR(out[0], -0.25, 1e-3);
  EXPECT_EQ(bridge.underrun_frames(), 0u);
  EXPECT_EQ(bridge.overflow_frames(), 0u);
  EXPECT_EQ(bridge.converter_errors(), 0u);
}

TEST(RateBridge, ResetStartsOverWithTheSameDelay) {
  RateBridgeOptions options;
  options.max_period = Samples{64};
  RateBridge bridge(options);
  std::vector<double> ones(64, 1.0), out(64);
  const auto run = [&](int periods) {
    for (int i = 0; i < periods; ++i) {
      const std::span<const double> in(ones);
      bridge.process(std::span<const std::span<const double>>(&in, 1), out,
                     [](std::span<const std::span<const double>> m, std::span<double> y) { std::copy(m[0].begin(), m[0].end(), y.begin()); });
    }
  };
  run(100);
  EXPECT_NEAR(out[63], 1.0, 1e-3);
  bridge.reset();
  run(1);
  EXPECT_EQ(out[0], 0.0);  // the priming again
}

TEST(RateBridge, BadOptionsAreNamed) {
  const auto message = [](const RateBridgeOptions& o) {
    try {
      RateBridge bridge(o);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  RateBridgeOptions o;
  o.max_period = Samples{0};
  EXPECT_NE(message(o).find("max_period"), std::string::npos) << message(o);
  o = {};
  o.input_channels = 0;
  EXPECT_NE(message(o).find("input_channels"), std::string::npos) << message(o);
  o = {};
  o.device_rate = Hertz{3000.0 * 300};
  EXPECT_NE(message(o).find("outside libsamplerate's"), std::string::npos) << message(o);
  o = {};
  o.model_rate = Hertz{-1.0};
  EXPECT_NE(message(o).find("finite and > 0"), std::string::npos) << message(o);
}

}  // namespace
}  // namespace panelbass::engine

// The rate bridge's converters side by side at 44.1 and 48 kHz with 64-frame periods, the models' rate
// 3000 Hz: the latency the bridge adds (reported, and an impulse's centre of mass measured through it), the
// pass-band gain at 1190 Hz, the level of an alias tone (2200 Hz → 800 Hz), and the cost per device frame
// (decimate + identity + interpolate, best of 3). libsoxr (its minimum-phase recipes) is measured for how
// long it holds output back when streaming, which is why the bridge's default is a polyphase filter of its
// own (dsp/polyphase_resampler.h).
//   build/bin/rate_bridge_bench [SECONDS]
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <vector>

#include "dsp/random.h"
#include "dsp/sine_fit.h"
#include "engine/rate_bridge.h"

#ifdef PANELBASS_BENCH_SOXR
#include <soxr.h>
#endif

namespace {

using namespace panelbass;
using namespace panelbass::engine;

constexpr int kPeriod = 64;
constexpr double kModelRate = 3000.0;

/// `x` through a bridge of `quality` at `fs`, the identity in place of the chain, in 64-frame periods.
std::vector<double> through(ResampleQuality quality, double fs, const std::vector<double>& x, double* ns_per_frame = nullptr) {
  RateBridgeOptions options;
  options.device_rate = Hertz{fs};
  options.model_rate = Hertz{kModelRate};
  options.max_period = Samples{kPeriod};
  options.quality = quality;
  RateBridge bridge(options);
  std::vector<double> y(x.size() / kPeriod * kPeriod);
  const auto started = std::chrono::steady_clock::now();
  for (std::size_t pos = 0; pos < y.size(); pos += kPeriod) {
    const std::span<const double> in(x.data() + pos, kPeriod);
    bridge.process(std::span<const std::span<const double>>(&in, 1), std::span<double>(y.data() + pos, kPeriod),
                   [](std::span<const std::span<const double>> m, std::span<double> out) { std::copy(m[0].begin(), m[0].end(), out.begin()); });
  }
  if (ns_per_frame != nullptr) {
    *ns_per_frame = static_cast<double>(std::chrono::nanoseconds(std::chrono::steady_clock::now() - started).count()) /
                    static_cast<double>(y.size());
  }
  return y;
}

double level_at(const std::vector<double>& y, std::size_t from, double fs, double f) {
  const Eigen::Map<const Eigen::VectorXd> tail(y.data() + from, static_cast<Eigen::Index>(y.size() - from));
  const Eigen::Vector3d c = dsp::fit_sine(tail, fs, f).coefficients;
  return std::hypot(c[0], c[1]);
}

std::vector<double> sine(double f, double fs, std::size_t n) {
  std::vector<double> x(n);
  for (std::size_t k = 0; k < n; ++k) x[k] = 0.5 * std::sin(2.0 * std::numbers::pi * f * static_cast<double>(k) / fs);
  return x;
}

void bridge_row(ResampleQuality quality, double fs, double seconds) {
  RateBridgeOptions options;
  options.device_rate = Hertz{fs};
  options.max_period = Samples{kPeriod};
  options.quality = quality;
  const RateBridgeLatency latency = RateBridge(options).latency();
  std::vector<double> impulse(static_cast<std::size_t>(fs / 2), 0.0);
  constexpr std::size_t kAt = 5003;
  impulse[kAt] = 1.0;
  const std::vector<double> h = through(quality, fs, impulse);
  double area = 0.0, moment = 0.0;
  for (std::size_t k = 0; k < h.size(); ++k) {
    area += h[k];
    moment += static_cast<double>(k) * h[k];
  }
  const double measured_ms = 1e3 * (moment / area - static_cast<double>(kAt)) / fs;
  const auto n = static_cast<std::size_t>(fs);
  const double gain = level_at(through(quality, fs, sine(1190.0, fs, n)), n / 2, fs, 1190.0) / 0.5;
  const double alias = level_at(through(quality, fs, sine(2200.0, fs, n)), n / 2, fs, 800.0) / 0.5;
  dsp::Rng rng(3);
  std::vector<double> noise(static_cast<std::size_t>(seconds * fs));
  for (double& x : noise) x = rng.uniform(-0.5, 0.5);
  double best = 1e300;
  for (int run = 0; run < 3; ++run) {
    double ns = 0.0;
    through(quality, fs, noise, &ns);
    best = std::min(best, ns);
  }
  std::printf("| %-12s | %5.1f kHz | %6.3f ms (%3d samples) | %6.3f ms | %+8.5f dB | %6.1f dB | %6.1f ns |\n",
              resample_quality_name(quality), fs / 1e3, latency.total_ms, latency.total_samples, measured_ms,
              20.0 * std::log10(gain), 20.0 * std::log10(alias), best);
}

#ifdef PANELBASS_BENCH_SOXR
/// Device frames libsoxr takes in before its first output, streaming 64-frame periods (decimating), and
/// model samples before its first output (interpolating, 4 at a time).
void soxr_row(double fs, unsigned long recipe, const char* name) {
  const auto hold_back = [&](double from, double to, std::size_t chunk) {
    soxr_error_t error = nullptr;
    const soxr_io_spec_t io = soxr_io_spec(SOXR_FLOAT64_I, SOXR_FLOAT64_I);
    const soxr_quality_spec_t q = soxr_quality_spec(recipe, SOXR_MINIMUM_PHASE);
    const soxr_runtime_spec_t rt = soxr_runtime_spec(1);
    soxr_t s = soxr_create(from, to, 1, &error, &io, &q, &rt);
    std::vector<double> in(chunk, 0.0), out(100000);
    std::size_t taken = 0;
    for (int i = 0; i < 100000; ++i) {
      std::size_t used = 0, made = 0;
      soxr_process(s, in.data(), chunk, &used, out.data(), out.size(), &made);
      taken += used;
      if (made > 0) break;
    }
    soxr_delete(s);
    return 1e3 * static_cast<double>(taken) / from;
  };
  std::printf("| libsoxr %-4s | %5.1f kHz | first output after %.1f ms of input decimating, %.1f ms interpolating (minimum phase) |\n",
              name, fs / 1e3, hold_back(fs, kModelRate, kPeriod), hold_back(kModelRate, fs, 4));
}
#endif

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
  std::printf("rate bridge, 64-frame periods, model rate 3000 Hz, %.0f s of noise per cost figure (best of 3)\n\n", seconds);
  std::printf("| converters   | device    | latency reported        | impulse   | 1190 Hz gain | alias 2200 Hz | cost/frame |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (const double fs : {48000.0, 44100.0}) {
    for (const ResampleQuality q : {ResampleQuality::low_latency, ResampleQuality::fastest, ResampleQuality::medium}) bridge_row(q, fs, seconds);
  }
#ifdef PANELBASS_BENCH_SOXR
  std::printf("\n");
  for (const double fs : {48000.0, 44100.0}) {
    soxr_row(fs, SOXR_QQ, "QQ");
    soxr_row(fs, SOXR_LQ, "LQ");
    soxr_row(fs, SOXR_HQ, "HQ");
  }
#endif
  return 0;
}

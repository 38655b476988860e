#include "evaluation/level_sweep.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#include "dsp/harmonics.h"
#include "engine/offline_renderer.h"
#include "models/control/model_probes.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::evaluation {
namespace {

// The plant-alone amplitude is iterated until its fundamental is within this ratio of the chain's (0.01 dB).
constexpr double kLevelTolerance = 1.00115;
constexpr int kMaxLevelIterations = 12;

/// A program rendered: the sensor's output and the drive.
struct Record {
  Eigen::VectorXd measured, drive;
  bool limited = false;  // the chain's limiter changed a sample (the program needs more than the chain gives)
  bool over_range = false;  // a sample asked for full scale or more (the engine's needs-more-drive count)
  double peak_demand = 0.0;  // the largest |drive| the chain asked for before its limiter
};

Record render_chain(const engine::ChainConfig& config, const models::PlantConfig& plant, const Eigen::VectorXd& program,
                    std::uint64_t seed) {
  std::unique_ptr<engine::Chain> chain = engine::make_chain(config);
  engine::RenderOptions ro;
  ro.block = engine::Samples{config.block};
  ro.plant = plant;
  ro.noise_seed = seed;
  engine::Rendering r = engine::render(*chain, program, ro);
  const engine::MetricsSnapshot m = chain->metrics().snapshot();
  return {std::move(r.measured), std::move(r.drive), m.limited_samples > 0, m.over_range_samples > 0, m.peak_demand};
}

Record render_plant(const models::PlantConfig& plant, const Eigen::VectorXd& drive, std::uint64_t seed) {
  const Eigen::VectorXd clamped = drive.cwiseMax(-1.0).cwiseMin(1.0);
  const bool clamped_any = (clamped - drive).cwiseAbs().maxCoeff() > 0.0;
  return {models::simulate(plant, clamped, seed).y, clamped, clamped_any, clamped_any, drive.cwiseAbs().maxCoeff()};
}

HarmonicFigures figures_of(const Record& r, Eigen::Index n, double fs, double f, int harmonics) {
  const dsp::HarmonicLevels levels = dsp::harmonic_levels(r.measured.tail(n), fs, f, harmonics);
  return {levels.amplitude.front(), levels.thd_percent(), levels.relative_db(2), levels.relative_db(3),
          r.drive.tail(n).cwiseAbs().maxCoeff()};
}

/// Amplitude of `x` at `f` (the DFT at that frequency).
double tone(const Eigen::VectorXd& x, double fs, double f) { return dsp::harmonic_levels(x, fs, f, 1).amplitude.front(); }

/// The scale s of `shape` at which the plant alone gives `target` at `f` in the sensor (measured by `level`), by
/// the ratio iteration s ← s·target/level(s) from `start`; returns s and the last record in `record` (NaN when
/// the plant does not reach the target within full drive).
template <class Level>
double match_level(const models::PlantConfig& plant, const Eigen::VectorXd& shape, double target, double start,
                   std::uint64_t seed, const Level& level, Record& record) {
  const double full = 1.0 / shape.cwiseAbs().maxCoeff();
  double s = std::min(start, full);
  for (int it = 0; it < kMaxLevelIterations; ++it) {
    record = render_plant(plant, s * shape, seed);
    const double got = level(record);
    const double ratio = target / got;
    if (ratio < kLevelTolerance && ratio > 1.0 / kLevelTolerance) return s;
    if (!(got > 0.0)) break;
    if (s >= full && ratio > 1.0) break;  // at full drive and still short
    s = std::min(full, s * ratio);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

/// The THD (percent) that white sensor noise of rms σ shows over n samples at a fundamental of amplitude a1
/// with `count` harmonics: each single-bin DFT amplitude of the noise has mean square 4σ²/n.
double noise_floor_pct(double sigma, Eigen::Index n, double a1, int count) {
  return 100.0 * std::sqrt(static_cast<double>(count) * 4.0 * sigma * sigma / static_cast<double>(n)) / a1;
}

void require_options(const LevelSweepOptions& o, double fs) {
  if (o.frequencies_hz.empty()) throw std::invalid_argument("level sweep: no probe frequency");
  models::require_probe_hz(o.frequencies_hz, fs, "level sweep");
  if (o.program_amplitudes.empty()) throw std::invalid_argument("level sweep: no program amplitude");
  for (double a : o.program_amplitudes) {
    if (!(a > 0.0 && a <= 1.0)) throw std::invalid_argument("level sweep: a program amplitude must be in (0, 1]");
  }
  if (o.harmonics < 3) throw std::invalid_argument("level sweep: at least 3 harmonics are needed for H2 and H3");
  if (!(o.analysis_seconds >= 0.5 && o.settle_seconds >= 0.2)) {
    throw std::invalid_argument("level sweep: analysis_seconds must be >= 0.5 and settle_seconds >= 0.2");
  }
  if (!(o.imd_low_hz > 0.0 && o.imd_high_hz > 2.0 * o.imd_low_hz && o.imd_high_hz + 2.0 * o.imd_low_hz < fs / 2.0 &&
        o.imd_ratio > 0.0)) {
    throw std::invalid_argument("level sweep: the two tones need 0 < low, 2·low < high, high + 2·low < fs/2, ratio > 0");
  }
}

}  // namespace

double LevelSweep::worst_cut_db(double frequency_hz) const {
  double worst = std::numeric_limits<double>::quiet_NaN();
  for (const LevelCurve& c : curves) {
    if (c.frequency_hz != frequency_hz) continue;
    for (const LevelPoint& p : c.points) {
      if (!p.reachable) continue;
      // within 3 dB of the floor counts as having reached it (the "down to that floor")
      const double cut = p.chain.thd_pct < p.noise_floor_pct * std::sqrt(2.0) ? std::numeric_limits<double>::infinity()
                                                                               : p.cut_db;
      worst = std::isnan(worst) ? cut : std::min(worst, cut);
    }
  }
  return worst;
}

LevelSweep sweep_levels(const engine::ChainConfig& config, const models::PlantConfig& plant,
                        const LevelSweepOptions& o, const std::function<void(std::size_t, std::size_t)>& progress) {
  const double fs = config.fs;
  if (std::abs(plant.fs - fs) > 1e-9 * fs) {
    throw std::invalid_argument("level sweep: the plant runs at " + std::to_string(plant.fs) + " Hz, the chain at " +
                                std::to_string(fs) + " Hz");
  }
  require_options(o, fs);
  const models::ProbeTiming timing{0.2, o.settle_seconds, o.analysis_seconds};
  const auto n = static_cast<Eigen::Index>(o.analysis_seconds * fs);
  const double sigma = plant.sensor.noise_rms_V;
  const std::size_t total = (o.frequencies_hz.size() + 1) * o.program_amplitudes.size();
  std::size_t done = 0;

  LevelSweep sweep;
  for (double f : o.frequencies_hz) {
    LevelCurve curve;
    curve.frequency_hz = f;
    const Eigen::VectorXd unit = models::probe_sine(f, 1.0, fs, timing);
    int count = 0;  // harmonics 2..harmonics below fs/2
    for (int h = 2; h <= o.harmonics; ++h) count += h * f < fs / 2.0 ? 1 : 0;
    for (double a : o.program_amplitudes) {
      LevelPoint p;
      p.program_amplitude = a;
      const Record chained = render_chain(config, plant, a * unit, o.seed);
      p.chain = figures_of(chained, n, fs, f, o.harmonics);
      Record alone;
      p.plant_drive = match_level(
          plant, unit, p.chain.fundamental, std::max(a, p.chain.drive_peak), o.seed,
          [&](const Record& r) { return tone(r.measured.tail(n), fs, f); }, alone);
      p.plant = figures_of(alone, n, fs, f, o.harmonics);
      p.cut_db = 20.0 * std::log10(p.plant.thd_pct / p.chain.thd_pct);
      p.noise_floor_pct = noise_floor_pct(sigma, n, p.chain.fundamental, count);
      p.reachable = !chained.limited && std::isfinite(p.plant_drive);
      p.needs_more_drive = chained.over_range;
      p.peak_demand = chained.peak_demand;
      curve.points.push_back(p);
      if (progress) progress(++done, total);
    }
    sweep.curves.push_back(std::move(curve));
  }

  // [IMD] sidebands f_high ± f_low, f_high ± 2·f_low over the high tone, at equal low-tone output
  const Eigen::VectorXd two_tone = models::probe_sine(o.imd_low_hz, 1.0, fs, timing) +
                                   models::probe_sine(o.imd_high_hz, 1.0 / o.imd_ratio, fs, timing);
  const auto imd_pct = [&](const Record& r) {
    const Eigen::VectorXd y = r.measured.tail(n);
    double sidebands = 0.0;
    for (double s : {-2.0, -1.0, 1.0, 2.0}) sidebands += std::pow(tone(y, fs, o.imd_high_hz + s * o.imd_low_hz), 2);
    return 100.0 * std::sqrt(sidebands) / tone(y, fs, o.imd_high_hz);
  };
  const auto low_tone = [&](const Record& r) { return tone(r.measured.tail(n), fs, o.imd_low_hz); };
  for (double a : o.program_amplitudes) {
    ImdPoint p;
    p.program_amplitude = a;
    const double scale = a;  // the low tone at a, the high one at a/ratio
    const Record chained = render_chain(config, plant, scale * two_tone, o.seed);
    p.output_low = low_tone(chained);
    p.chain_imd_pct = imd_pct(chained);
    Record alone;
    p.plant_scale = match_level(plant, two_tone, p.output_low, scale, o.seed, low_tone, alone);
    p.plant_imd_pct = imd_pct(alone);
    p.cut_db = 20.0 * std::log10(p.plant_imd_pct / p.chain_imd_pct);
    p.reachable = !chained.limited && std::isfinite(p.plant_scale);
    sweep.imd.push_back(p);
    if (progress) progress(++done, total);
  }
  return sweep;
}

}  // namespace panelbass::evaluation

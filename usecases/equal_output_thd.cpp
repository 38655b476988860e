#include "usecases/equal_output_thd.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <span>
#include <stdexcept>

#include "engine/metrics.h"
#include "models/io/number_text.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

using models::number_text;

// The transducer alone is matched to the chain's output within this (0.1 dB): THD moves by about twice the
// level's change for a third harmonic, so the comparison is then good to 0.2 dB.
constexpr double kMatchDb = 0.1;
// A reading is noise-bound when the noise moves it by more than this, dB (or it is within 3 dB of its floor).
constexpr double kMaxUncertaintyDb = 1.0;
// A cut below minus this is called worse, dB (the level match alone moves a THD by up to 0.2 dB).
constexpr double kWorseDb = 0.5;
// The fade each probe starts and ends with, seconds.
constexpr double kFadeSeconds = 0.05;

// Where one probe sits in a stepped recording.
struct Slot {
  Eigen::Index start = 0;     // first sample of its analysis window
  Eigen::Index length = 0;    // the window, whole periods
};

// One stepped recording: the probes' sines one after another, each faded in, settled, analysed, faded out.
struct Stepped {
  Eigen::VectorXd signal;
  std::vector<Slot> slots;
};

Eigen::Index samples_of(double seconds, double fs) { return static_cast<Eigen::Index>(std::llround(seconds * fs)); }

// The analysis window for `f`: the whole periods nearest `seconds`, at least one.
Eigen::Index window_of(double f, double seconds, double fs) {
  const double periods = std::max(1.0, std::round(seconds * f));
  return static_cast<Eigen::Index>(std::llround(periods * fs / f));
}

// Sines of `amplitudes` at `frequencies` (pairwise), stepped.
Stepped stepped(const std::vector<double>& frequencies, const std::vector<double>& amplitudes, const EqualOutputSettings& s,
                double fs) {
  const Eigen::Index fade = samples_of(kFadeSeconds, fs), settle = samples_of(s.settle_seconds, fs);
  Stepped out;
  Eigen::Index total = 0;
  for (double f : frequencies) total += settle + window_of(f, s.analysis_seconds, fs) + fade;
  out.signal = Eigen::VectorXd::Zero(total);
  Eigen::Index at = 0;
  for (std::size_t p = 0; p < frequencies.size(); ++p) {
    const double f = frequencies[p];
    const Eigen::Index window = window_of(f, s.analysis_seconds, fs), n = settle + window + fade;
    for (Eigen::Index k = 0; k < n; ++k) {
      double gain = 1.0;
      if (k < fade) gain = 0.5 - 0.5 * std::cos(std::numbers::pi * static_cast<double>(k) / static_cast<double>(fade));
      if (k >= settle + window) {
        gain = 0.5 + 0.5 * std::cos(std::numbers::pi * static_cast<double>(k - settle - window) / static_cast<double>(fade));
      }
      out.signal[at + k] = gain * amplitudes[p] * std::sin(2.0 * std::numbers::pi * f * static_cast<double>(k) / fs);
    }
    out.slots.push_back({at + settle, window});
    at += n;
  }
  return out;
}

// The amplitude of `x` at `f` (the DFT at that frequency).
double fundamental(const Eigen::VectorXd& x, double fs, double f) {
  return dsp::harmonic_levels(x, fs, f, 1).amplitude.front();
}

ThdReading reading_of(const Eigen::VectorXd& window, double fs, double f, const std::string& what) {
  const std::optional<dsp::SteadyThd> thd = dsp::steady_thd(window, fs, f);
  if (!thd) throw std::runtime_error("the " + number_text(f) + " Hz probe " + what + ": no fundamental to read a THD from");
  ThdReading r;
  r.thd_pct = thd->thd_pct;
  r.floor_pct = thd->floor_pct;
  r.uncertainty_db = thd->uncertainty_db;
  r.noise_bound = thd->at_floor || !(thd->uncertainty_db <= kMaxUncertaintyDb);
  if (r.noise_bound) {
    r.at_most_pct = thd->at_floor ? std::sqrt(2.0) * thd->floor_pct
                                  : thd->thd_pct * std::pow(10.0, 2.0 * thd->uncertainty_db / 20.0);
  }
  return r;
}

// The chain's drive for a stepped program, run offline exactly as the engine runs it, with what its limiter did
// per probe.
struct ChainRun {
  Eigen::VectorXd drive;
  std::vector<bool> limited;  // per slot: the limiter changed a sample of its probe
  std::vector<double> peak;   // per slot: the largest |drive| over its probe
};

ChainRun run_chain(const engine::ChainConfig& config, const Stepped& program, double fs) {
  const std::unique_ptr<engine::Chain> chain = engine::make_chain(config);
  const Eigen::Index block = chain->options().spec.max_block;
  ChainRun out;
  out.drive = Eigen::VectorXd::Zero(program.signal.size());
  const Eigen::Index fade = samples_of(kFadeSeconds, fs);
  Eigen::Index done = 0;
  for (const Slot& slot : program.slots) {
    const Eigen::Index end = slot.start + slot.length + fade;  // the probe's own fade out included
    const std::uint64_t limited_before = chain->metrics().snapshot().limited_samples;
    for (Eigen::Index k = done; k < end; k += block) {
      const Eigen::Index n = std::min(block, end - k);
      chain->process_block(std::span<const double>(program.signal.data() + k, static_cast<std::size_t>(n)),
                           std::span<double>(out.drive.data() + k, static_cast<std::size_t>(n)));
    }
    out.limited.push_back(chain->metrics().snapshot().limited_samples > limited_before);
    out.peak.push_back(out.drive.segment(done, end - done).cwiseAbs().maxCoeff());
    done = end;
  }
  return out;
}

// The sensor of `played`, checked to be as long as the drive.
const Eigen::VectorXd& sensor_of(const Playback& played, Eigen::Index samples) {
  if (played.sensor.size() == 0) {
    throw std::runtime_error("the backend records no sensor, and verify reads each THD from it (on a card: panelbass serve --sensor-channel)");
  }
  if (played.sensor.size() != samples) {
    throw std::runtime_error("the backend returned " + std::to_string(played.sensor.size()) + " sensor samples for a drive of " +
                             std::to_string(samples));
  }
  return played.sensor;
}

std::string point_name(const EqualOutputPoint& p) {
  return number_text(p.frequency_hz) + " Hz at program level " + number_text(p.program_level);
}

nlohmann::json number_or_null(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); }

nlohmann::json reading_json(const ThdReading& r) {
  nlohmann::json j = {{"thd_pct", r.noise_bound ? nlohmann::json(nullptr) : nlohmann::json(r.thd_pct)},
                      {"floor_pct", r.floor_pct},
                      {"noise_bound", r.noise_bound},
                      {"uncertainty_db", std::isfinite(r.uncertainty_db) ? nlohmann::json(r.uncertainty_db) : nlohmann::json(nullptr)}};
  if (r.noise_bound) j["at_most_pct"] = r.at_most_pct;
  return j;
}

}  // namespace

nlohmann::json to_json(const EqualOutputSettings& s) {
  return {{"frequencies", s.frequencies},       {"levels", s.levels},          {"settle_seconds", s.settle_seconds},
          {"analysis_seconds", s.analysis_seconds}, {"max_plays", s.max_plays}};
}

void check(const EqualOutputSettings& s, double fs) {
  if (s.frequencies.empty() || s.frequencies.size() > 16) throw RequestError("frequencies", "give 1 to 16 probe frequencies");
  for (double f : s.frequencies) {
    if (!(f >= 10.0 && f <= fs / 4.0)) {
      throw RequestError("frequencies", number_text(f) + " Hz is outside [10, fs/4 = " + number_text(fs / 4.0) +
                                               "] Hz (its third harmonic must stay below fs/2)");
    }
  }
  if (s.levels.empty() || s.levels.size() > 16) throw RequestError("levels", "give 1 to 16 program levels");
  for (double a : s.levels) {
    if (!(a > 0.0 && a <= 1.0)) throw RequestError("levels", number_text(a) + " is outside (0, 1]");
  }
  if (!(s.settle_seconds >= 0.1 && s.settle_seconds <= 5.0)) throw RequestError("settle_seconds", "must be within [0.1, 5]");
  if (!(s.analysis_seconds >= 0.2 && s.analysis_seconds <= 10.0)) throw RequestError("analysis_seconds", "must be within [0.2, 10]");
  if (s.max_plays < 1 || s.max_plays > 8) throw RequestError("max_plays", "must be within [1, 8]");
}

std::optional<double> EqualOutputReport::credited_cut(const EqualOutputPoint& p) {
  if (p.cut_db) return p.cut_db;
  return p.cut_at_least_db;
}

std::optional<double> EqualOutputReport::worst_cut_db(double frequency_hz) const {
  std::optional<double> worst;
  for (const EqualOutputPoint& p : points) {
    if (p.frequency_hz != frequency_hz || !p.reachable) continue;
    const std::optional<double> cut = credited_cut(p);
    if (cut) worst = worst ? std::min(*worst, *cut) : *cut;
  }
  return worst;
}

nlohmann::json EqualOutputReport::to_json() const {
  nlohmann::json rows = nlohmann::json::array(), worst = nlohmann::json::object();
  std::vector<double> seen;
  for (const EqualOutputPoint& p : points) {
    nlohmann::json row = {{"frequency_hz", p.frequency_hz},
                          {"program_level", p.program_level},
                          {"reachable", p.reachable},
                          {"chain_drive_peak", p.chain_drive_peak},
                          {"output_level", p.output_level},
                          {"plant_drive", p.reachable ? nlohmann::json(p.plant_drive) : nlohmann::json(nullptr)},
                          {"plant_output_level", p.reachable ? nlohmann::json(p.plant_output_level) : nlohmann::json(nullptr)},
                          {"chain", reading_json(p.chain)},
                          {"plant", p.reachable ? reading_json(p.plant) : nlohmann::json(nullptr)},
                          {"thd_cut_db", number_or_null(p.cut_db)},
                          {"thd_cut_at_least_db", number_or_null(p.cut_at_least_db)}};
    if (!p.reachable) row["unreachable_because"] = p.unreachable_because;
    rows.push_back(row);
    if (std::find(seen.begin(), seen.end(), p.frequency_hz) == seen.end()) {
      seen.push_back(p.frequency_hz);
      worst[number_text(p.frequency_hz)] = number_or_null(worst_cut_db(p.frequency_hz));
    }
  }
  return {{"points", rows}, {"plays", plays}, {"warnings", warnings}, {"worst_cut_db", worst}};
}

nlohmann::json EqualOutputReport::plots() const {
  nlohmann::json plots = nlohmann::json::object();
  for (const EqualOutputPoint& p : points) {
    if (!p.reachable) continue;
    nlohmann::json& plot = plots["thd_vs_level_" + std::to_string(std::lround(p.frequency_hz))];
    if (plot.is_null()) plot = {{"level", nlohmann::json::array()}, {"chain_thd_pct", nlohmann::json::array()}, {"plant_thd_pct", nlohmann::json::array()}};
    plot["level"].push_back(p.output_level);
    // a noise-bound THD is drawn at what it is at most
    plot["chain_thd_pct"].push_back(p.chain.noise_bound ? p.chain.at_most_pct : p.chain.thd_pct);
    plot["plant_thd_pct"].push_back(p.plant.noise_bound ? p.plant.at_most_pct : p.plant.thd_pct);
  }
  return plots;
}

EqualOutputReport verify_equal_output(const EqualOutputRequest& request, const PlayFunction& play, Progress& progress) {
  const EqualOutputSettings& s = request.settings;
  const double fs = request.chain.fs;
  check(s, fs);
  if (!(request.safe_level > 0.0 && request.safe_level <= 1.0)) throw RequestError("safe_level", "must be within (0, 1]");
  EqualOutputReport report;
  // Every point, frequency-major.
  std::vector<double> freqs, levels;
  for (double f : s.frequencies) {
    for (double a : s.levels) {
      freqs.push_back(f);
      levels.push_back(a);
      EqualOutputPoint p;
      p.frequency_hz = f;
      p.program_level = a;
      report.points.push_back(p);
    }
  }
  const std::size_t n = report.points.size();
  const double plays_total = 1.0 + s.max_plays;
  // 1. The chain: its drive offline, played where it stays within the safe level with its limiter untouched.
  progress.report(0.0, "playing the probes through the chain");
  const Stepped program = stepped(freqs, levels, s, fs);
  ChainRun chain = run_chain(request.chain, program, fs);
  const Eigen::Index fade = samples_of(kFadeSeconds, fs), settle = samples_of(s.settle_seconds, fs);
  for (std::size_t p = 0; p < n; ++p) {
    EqualOutputPoint& point = report.points[p];
    point.chain_drive_peak = chain.peak[p];
    if (chain.limited[p] || chain.peak[p] > request.safe_level) {
      point.unreachable_because = chain.limited[p] ? "the chain's limiter acts (drive peak " + number_text(chain.peak[p], 3) + ")"
                                                   : "the chain's drive peaks at " + number_text(chain.peak[p], 3) +
                                                         ", beyond the safe level " + number_text(request.safe_level);
      const Slot& slot = program.slots[p];
      chain.drive.segment(slot.start - settle, settle + slot.length + fade).setZero();  // not played
    }
  }
  const Playback through = play(chain.drive);
  ++report.plays;
  const Eigen::VectorXd& y_chain = sensor_of(through, chain.drive.size());
  std::vector<double> plant_drive(n, 0.0);
  std::vector<bool> searching(n, false);
  for (std::size_t p = 0; p < n; ++p) {
    EqualOutputPoint& point = report.points[p];
    if (!point.unreachable_because.empty()) continue;
    const Slot& slot = program.slots[p];
    point.output_level = fundamental(y_chain.segment(slot.start, slot.length), fs, point.frequency_hz);
    point.chain = reading_of(y_chain.segment(slot.start, slot.length), fs, point.frequency_hz, "through the chain");
    // The chain's drive at the fundamental is where the transducer alone starts.
    plant_drive[p] = std::min(request.safe_level, fundamental(chain.drive.segment(slot.start, slot.length), fs, point.frequency_hz));
    searching[p] = true;
  }
  // 2. The transducer alone: its sine's amplitude searched (s ← s·target/got) until its output matches.
  const double tolerance = std::pow(10.0, kMatchDb / 20.0);
  for (int pass = 0; pass < s.max_plays; ++pass) {
    std::vector<std::size_t> which;
    std::vector<double> f_pass, a_pass;
    for (std::size_t p = 0; p < n; ++p) {
      if (!searching[p]) continue;
      which.push_back(p);
      f_pass.push_back(freqs[p]);
      a_pass.push_back(plant_drive[p]);
    }
    if (which.empty()) break;
    progress.report((1.0 + pass) / plays_total, "playing the transducer alone at the chain's output (pass " + std::to_string(pass + 1) + ")");
    const Stepped alone = stepped(f_pass, a_pass, s, fs);
    const Playback heard = play(alone.signal);
    ++report.plays;
    const Eigen::VectorXd& y = sensor_of(heard, alone.signal.size());
    for (std::size_t q = 0; q < which.size(); ++q) {
      const std::size_t p = which[q];
      EqualOutputPoint& point = report.points[p];
      const Slot& slot = alone.slots[q];
      const double got = fundamental(y.segment(slot.start, slot.length), fs, point.frequency_hz);
      point.plant_drive = plant_drive[p];
      point.plant_output_level = got;
      point.plant = reading_of(y.segment(slot.start, slot.length), fs, point.frequency_hz, "on the transducer alone");
      const double ratio = point.output_level / got;
      // Matched within 0.1 dB, or within what the noise lets either fundamental be read to (two standard
      // deviations: each single-bin amplitude carries 4σ²/N of the noise, the floor's share per harmonic).
      const double read_to = 1.0 + 2.0 * (point.chain.floor_pct + point.plant.floor_pct) / 100.0 / std::sqrt(5.0 - 1.0);
      const double within = std::max(tolerance, read_to);
      if (ratio < within && ratio > 1.0 / within) {
        searching[p] = false;
        point.reachable = true;
        continue;
      }
      if (!(got > 0.0) || (plant_drive[p] >= request.safe_level && ratio > 1.0)) {
        searching[p] = false;
        point.unreachable_because = "the transducer alone does not reach the chain's output within the safe level " +
                                    number_text(request.safe_level);
        continue;
      }
      plant_drive[p] = std::min(request.safe_level, plant_drive[p] * ratio);
    }
  }
  for (std::size_t p = 0; p < n; ++p) {
    EqualOutputPoint& point = report.points[p];
    if (searching[p]) {
      point.unreachable_because = "the transducer alone was not matched to the chain's output within " + number_text(kMatchDb) +
                                  " dB in " + std::to_string(s.max_plays) + " plays (" +
                                  number_text(20.0 * std::log10(point.output_level / point.plant_output_level), 2) + " dB off)";
      report.warnings.push_back(point_name(point) + ": " + point.unreachable_because);
    }
    if (!point.reachable) continue;
    // 3. The cut: a number when both read above their noise, a bound when the chain's is noise-bound.
    if (!point.chain.noise_bound && !point.plant.noise_bound && point.chain.thd_pct > 0.0) {
      point.cut_db = 20.0 * std::log10(point.plant.thd_pct / point.chain.thd_pct);
      if (*point.cut_db < -kWorseDb) {
        report.warnings.push_back(point_name(point) + ": the chain makes the distortion worse at equal output, THD " +
                                  number_text(point.plant.thd_pct, 3) + " % → " + number_text(point.chain.thd_pct, 3) + " % (" +
                                  number_text(*point.cut_db, 3) + " dB)");
      }
    } else if (!point.plant.noise_bound) {
      point.cut_at_least_db = 20.0 * std::log10(point.plant.thd_pct / point.chain.at_most_pct);
    }
  }
  progress.report(1.0, "verified");
  return report;
}

}  // namespace panelbass::usecases

#include "models/diagnosis/diagnosis_levels.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <optional>
#include <utility>

#include "models/diagnosis/diagnosis_fit.h"
#include "models/linear/linear_identification.h"
#include "models/validation/performance.h"

namespace panelbass::models::diagnosis_detail {
namespace {

// The rms of `u` after its first `init` samples.
double rms_after(const Eigen::VectorXd& u, Eigen::Index init) {
  const Eigen::Index n = u.size() - init;
  return n > 0 ? std::sqrt(u.tail(n).squaredNorm() / static_cast<double>(n)) : 0.0;
}

// A discrete pole's continuous-time image s = ln(z)·fs.
std::complex<double> s_plane(std::complex<double> z, double fs) { return std::log(z) * fs; }

// The pole of `tf` nearest `target` in the s-plane, within a third of |target|.
std::optional<std::complex<double>> pole_near(const TransferFunction& tf, std::complex<double> target, double fs) {
  std::optional<std::complex<double>> best;
  for (const std::complex<double>& z : tf.poles()) {
    if (z.imag() <= 0.0) continue;
    const std::complex<double> s = s_plane(z, fs);
    if (std::abs(s - target) < std::abs(target) / 3.0 && (!best || std::abs(s - target) < std::abs(*best - target))) best = s;
  }
  return best;
}

// The main resonance of `tf`: the complex pole (damping ratio 0.01–0.3, below fs/4) where the response peaks highest.
// Lighter poles are a pole–zero pair the fit left nearly cancelled; their spike is no resonance of the transducer.
std::optional<std::complex<double>> main_resonance(const TransferFunction& tf, double fs) {
  std::optional<std::complex<double>> best;
  double best_peak = 0.0;
  for (const std::complex<double>& z : tf.poles()) {
    if (z.imag() <= 0.0) continue;
    const std::complex<double> s = s_plane(z, fs);
    const double omega = std::abs(s), zeta = -s.real() / omega, f_d = s.imag() / (2.0 * M_PI);
    if (zeta < 0.01 || zeta > 0.3 || f_d > fs / 4.0) continue;
    const double peak = std::abs(tf.response(f_d, fs));
    if (peak > best_peak) best_peak = peak, best = s;
  }
  return best;
}

}  // namespace

ResonanceShift resonance_shift(const LinearModel& baseline, const std::vector<LevelRecord>& levels, Eigen::Index init) {
  ResonanceShift out;
  const double fs = baseline.fs;
  const std::optional<std::complex<double>> reference = main_resonance(baseline.tf, fs);
  if (!reference || levels.size() < 2) return out;
  LinearIdentificationSpec spec;
  spec.method = LinearMethod::oe;
  spec.order = baseline.tf.na();
  spec.delay = baseline.tf.nk;
  spec.fs = fs;
  spec.init = init;
  for (const LevelRecord& level : levels) {
    LevelResonance at{level.name, rms_after(level.u, init)};
    // Each quarter identified (judged on the next): four estimates of the pole at this level, whose spread says how
    // well one record places it.
    const Eigen::Index quarter = level.u.size() / kLevelParts;
    std::vector<std::complex<double>> poles;
    for (Eigen::Index k = 0; k < kLevelParts && quarter >= init + 512; ++k) {
      const Eigen::Index a = k * quarter, b = ((k + 1) % kLevelParts) * quarter;
      try {
        const LinearIdentification id = identify_linear(level.u.segment(a, quarter), level.y.segment(a, quarter),
                                                        level.u.segment(b, quarter), level.y.segment(b, quarter), spec);
        if (auto s = pole_near(id.model.tf, *reference, fs)) poles.push_back(*s);
      } catch (const std::exception&) {
        break;  // a part that cannot be identified: this level is not judged
      }
    }
    if (poles.size() == static_cast<std::size_t>(kLevelParts)) {
      at.found = true;
      double so = 0.0, ss = 0.0, soo = 0.0, sss = 0.0;
      for (const std::complex<double>& s : poles)
        so += std::abs(s), ss += -s.real(), soo += std::norm(s), sss += s.real() * s.real();
      const double n = kLevelParts;
      at.omega = so / n;
      at.sigma = ss / n;
      at.omega_sd = std::sqrt(std::max(0.0, (soo - n * at.omega * at.omega) / (n - 1.0)));
      at.sigma_sd = std::sqrt(std::max(0.0, (sss - n * at.sigma * at.sigma) / (n - 1.0)));
    }
    out.levels.push_back(at);
  }
  std::vector<const LevelResonance*> found;
  for (const LevelResonance& l : out.levels)
    if (l.found) found.push_back(&l);
  if (found.size() < 2) return out;
  std::sort(found.begin(), found.end(), [](const LevelResonance* a, const LevelResonance* b) { return a->drive_rms < b->drive_rms; });
  const LevelResonance &low = *found.front(), &high = *found.back();
  if (!(low.drive_rms > 0.0) || high.drive_rms < kLevelSpan * low.drive_rms) return out;
  out.judged = true;
  out.d_omega = high.omega - low.omega;
  out.d_sigma = high.sigma - low.sigma;
  // A level's mean of kLevelParts estimates has their variance over kLevelParts; pooled over the levels judged, with a
  // floor of 10⁻⁵ of |s| for parts that agree by chance.
  double var_omega = 0.0, var_sigma = 0.0;
  for (const LevelResonance* l : found) var_omega += l->omega_sd * l->omega_sd, var_sigma += l->sigma_sd * l->sigma_sd;
  const double floor = 1e-5 * std::abs(*reference), per_mean = static_cast<double>(found.size()) * kLevelParts;
  out.sd_omega = std::max(std::sqrt(2.0 * var_omega / per_mean), floor);
  out.sd_sigma = std::max(std::sqrt(2.0 * var_sigma / per_mean), floor);
  const double z_omega = std::abs(out.d_omega) / out.sd_omega, z_sigma = std::abs(out.d_sigma) / out.sd_sigma;
  // ω and σ are both rad/s: the pole's path in the s-plane must lie along one axis (within atan(1/kShiftDirection)).
  const double along_omega = std::abs(out.d_omega), along_sigma = std::abs(out.d_sigma);
  // Along σ, its sign says which damping: Rms(v) = Rm·(1 + r₂v²) damps more at speed, friction's share falls.
  out.moves = z_omega >= kShiftZ && along_omega >= kShiftDirection * along_sigma   ? "frequency"
              : z_sigma >= kShiftZ && along_sigma >= kShiftDirection * along_omega ? (out.d_sigma > 0.0 ? "decay" : "decay_falls")
                                                                                  : "neither";
  const std::string numbers = "from drive rms " + fixed(low.drive_rms, 3) + " to " + fixed(high.drive_rms, 3) +
                              " the main resonance's frequency moves " + fixed(out.d_omega / (2.0 * M_PI), 3) + " Hz (z " +
                              fixed(z_omega, 1) + ") and its decay rate " + fixed(out.d_sigma, 2) + " 1/s (z " + fixed(z_sigma, 1) + ")";
  out.sentence = out.moves == "frequency"     ? numbers + ": the stiffness changes with the level, not the damping (a spring)"
                 : out.moves == "decay"       ? numbers + ": the damping grows with the level, not the stiffness (a damping that rises with the speed)"
                 : out.moves == "decay_falls" ? numbers + ": the damping falls with the level, as a friction's share does, not as Rms(v)'s rises"
                                              : numbers + ": neither moves alone, so the levels do not tell a spring from a damping";
  return out;
}

ResonanceShift resonance_shift(const LinearModel& baseline, const LevelRecord& diagnosed, const std::vector<LevelRecord>& others,
                               Eigen::Index init) {
  std::vector<LevelRecord> levels{diagnosed};
  levels.insert(levels.end(), others.begin(), others.end());
  return resonance_shift(baseline, levels, init);
}

bool spring_or_damping(Effect a, Effect b) {
  return (a == Effect::cubic_stiffness && b == Effect::nonlinear_damping) || (a == Effect::nonlinear_damping && b == Effect::cubic_stiffness);
}

void name_by_resonance_shift(const ResonanceShift& shift, const Candidate*& chosen, const Candidate*& rival, double drive_margin,
                             FindingConfidence& confidence) {
  if (!shift.judged) return;
  if (shift.moves != "frequency" && shift.moves != "decay") {
    confidence.sentence += " At several levels " + shift.sentence + ".";
    return;
  }
  const Effect named = shift.moves == "frequency" ? Effect::cubic_stiffness : Effect::nonlinear_damping;
  if (chosen->effect != named) std::swap(chosen, rival);
  confidence.word = "likely";
  confidence.runner_up = to_string(rival->effect);
  confidence.runner_up_variant = rival->variant;
  confidence.sentence = "likely " + to_string(chosen->effect) + " rather than " + confidence.runner_up +
                        ": they look alike from the drive (BIC margin " + fixed(drive_margin, 1) + "), but at several levels " +
                        shift.sentence + ".";
}

nlohmann::json resonance_shift_to_json(const ResonanceShift& shift) {
  nlohmann::json levels = nlohmann::json::array();
  for (const LevelResonance& l : shift.levels)
    levels.push_back({{"record", l.name}, {"drive_rms", l.drive_rms}, {"found", l.found},
                      {"frequency_hz", l.omega / (2.0 * M_PI)}, {"decay_per_s", l.sigma},
                      {"frequency_sd_hz", l.omega_sd / (2.0 * M_PI)}, {"decay_sd_per_s", l.sigma_sd}});
  return {{"judged", shift.judged},
          {"levels", levels},
          {"frequency_shift_hz", shift.d_omega / (2.0 * M_PI)},
          {"frequency_shift_sd_hz", shift.sd_omega / (2.0 * M_PI)},
          {"decay_shift_per_s", shift.d_sigma},
          {"decay_shift_sd_per_s", shift.sd_sigma},
          {"moves", shift.moves},
          {"sentence", shift.sentence}};
}

bool is_linear_effect(Effect effect) {
  return effect == Effect::resonance || effect == Effect::antiresonance || effect == Effect::delay || effect == Effect::creep;
}

LevelVerdict judge_levels(Effect effect, const std::vector<LevelGain>& levels) {
  LevelVerdict v;
  if (effect == Effect::dc_offset || levels.size() < 2) return v;
  std::vector<LevelGain> sorted = levels;
  std::sort(sorted.begin(), sorted.end(), [](const LevelGain& a, const LevelGain& b) { return a.drive_rms < b.drive_rms; });
  const LevelGain &low = sorted.front(), &high = sorted.back();
  if (!(low.drive_rms > 0.0) || high.drive_rms < kLevelSpan * low.drive_rms) return v;
  const auto gain = [](const LevelGain& g) { return g.j_before_pct - g.j_after_pct; };
  if (!(gain(high) > 0.0)) return v;
  // ln(gain) = a + slope·ln(level), least squares over the levels where the finding gains.
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
  int n = 0;
  for (const LevelGain& g : sorted)
    if (gain(g) > 0.0) {
      const double x = std::log(g.drive_rms), y = std::log(gain(g));
      sx += x, sy += y, sxx += x * x, sxy += x * y, ++n;
    }
  const double spread = n * sxx - sx * sx;
  // Only the higher levels gain: it grows, at a rate the data do not give.
  v.slope = n >= 2 && spread > 0.0 ? (n * sxy - sx * sy) / spread : std::numeric_limits<double>::infinity();
  v.judged = true;
  v.grows = v.slope > kGrowthSlope;
  v.consistent = is_linear_effect(effect) ? !v.grows : v.grows;
  const std::string span = std::to_string(sorted.size()) + " levels (drive rms " + fixed(low.drive_rms, 3) + "–" +
                           fixed(high.drive_rms, 3) + ")";
  const std::string rate = std::isfinite(v.slope) ? "as the level to the power " + fixed(v.slope, 1) : "only at the higher levels";
  const std::string name = to_string(effect);
  if (v.grows)
    v.sentence = "its gain in J grows with the drive over " + span + ", " + rate + ": nonlinear" +
                 (v.consistent ? ", as " + name + " is" : ", which " + name + " (a linear mismatch) is not");
  else
    v.sentence = "its gain in J does not grow with the drive over " + span + " (" + rate + "): a linear mismatch" +
                 (v.consistent ? ", as " + name + " is" : ", not the nonlinear " + name);
  return v;
}

nlohmann::json levels_to_json(const std::vector<LevelGain>& levels, const LevelVerdict& verdict) {
  nlohmann::json records = nlohmann::json::array();
  for (const LevelGain& g : levels)
    records.push_back({{"record", g.name}, {"drive_rms", g.drive_rms}, {"J_val_before_pct", g.j_before_pct},
                       {"J_val_after_pct", g.j_after_pct}});
  return {{"records", records},
          {"judged", verdict.judged},
          {"slope", verdict.judged && std::isfinite(verdict.slope) ? nlohmann::json(verdict.slope) : nlohmann::json(nullptr)},
          {"grows_with_level", verdict.grows},
          {"consistent", verdict.consistent},
          {"sentence", verdict.sentence}};
}

void judge_at_levels(Finding& f, const AugmentedModel& before, const AugmentedModel& after, const LevelRecord& diagnosed,
                     const std::vector<LevelRecord>& others, Eigen::Index init) {
  if (others.empty()) return;
  std::vector<LevelGain> gains{{diagnosed.name, rms_after(diagnosed.u, init), f.j_val_before_pct, f.j_val_after_pct}};
  for (const LevelRecord& level : others)
    gains.push_back({level.name, rms_after(level.u, init), j_percent(simulate_augmented(before, level.u, level.y, init), level.y, init),
                     j_percent(simulate_augmented(after, level.u, level.y, init), level.y, init)});
  const LevelVerdict verdict = judge_levels(f.effect, gains);
  f.evidence["levels"] = levels_to_json(gains, verdict);
  if (!verdict.judged) return;
  const std::string sentence = f.confidence.value("sentence", "");
  if (!verdict.consistent) {
    f.confidence["word"] = "ambiguous";
    f.confidence["sentence"] = "ambiguous: " + verdict.sentence + ". " + sentence;
  } else {
    f.confidence["sentence"] = sentence + " Levels: " + verdict.sentence + ".";
  }
}

}  // namespace panelbass::models::diagnosis_detail

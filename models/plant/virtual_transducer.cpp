#include "models/plant/virtual_transducer.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>


namespace panelbass::models {
namespace {

// State layout: coil current, displacement, velocity, voice-coil temperature rise, then two states per
// panel mode, then the analog filters' states, then (with creep) the suspension's relaxed displacement.
constexpr int kCurrent = 0;
constexpr int kDisplacement = 1;
constexpr int kVelocity = 2;
constexpr int kTemperature = 3;
constexpr double kMmPerM = 1000.0;
// Keeps a strongly nonlinear inductance (user-configured) from reaching zero and blowing up di/dt.
constexpr double kMinInductanceFraction = 0.05;
// The coil's time constant Le/R held at half an integration step at least: explicit RK4 follows a decay
// exp(−t·R/Le) only while h·R/Le < 2.785, and past it the current grows without bound, to NaN for good
// (panel-exciter-le-i's Le(i) = Le0·(1 − 0.08·i²) at a 160 Hz drive of 0.8: its 5 % floor gave h·R/Le = 5.6).
constexpr double kMinCoilTimeConstantSteps = 0.5;

// Soft clipper: identity up to `level`, then a tanh knee of width `knee` (continuous slope).
double soft_clip(double u, double level, double knee) noexcept {
  const double a = std::abs(u);
  if (a <= level) return u;
  return std::copysign(level + knee * std::tanh((a - level) / knee), u);
}

// The coloured noise's first-order sections at rate fs, scaled so that their sum has the standard deviation rms.
// lowpass: one section at the corner. pink: corners spaced by √10 over [low, high], each fed by its own white
// noise of density ∝ 1/corner, so that the sum's density falls as 1/f between the outer corners.
template <class Section>
std::vector<Section> noise_sections(const ColouredNoise& n, double fs) {
  std::vector<double> corners;
  if (n.rms_V <= 0.0) return {};
  if (n.shape == NoiseShape::lowpass) {
    corners.push_back(n.corner_hz);
  } else {
    const int count = 1 + static_cast<int>(std::ceil(2.0 * std::log10(n.high_hz / n.low_hz)));
    for (int k = 0; k < count; ++k) corners.push_back(n.low_hz * std::pow(n.high_hz / n.low_hz, k / (count - 1.0)));
  }
  std::vector<Section> out;
  double variance = 0.0;
  for (double f : corners) {
    Section s;
    s.a = std::exp(-2.0 * std::numbers::pi * f / fs);
    // lowpass: unit variance; pink: the white density ∝ 1/f, its DC gain 1: g = (1 − a)/√f.
    s.g = n.shape == NoiseShape::lowpass ? std::sqrt(1.0 - s.a * s.a) : (1.0 - s.a) / std::sqrt(f);
    variance += s.g * s.g / (1.0 - s.a * s.a);
    out.push_back(s);
  }
  for (Section& s : out) s.g *= n.rms_V / std::sqrt(variance);
  return out;
}

}  // namespace

VirtualTransducer::VirtualTransducer(PlantConfig config, std::uint64_t noise_seed)
    : config_(std::move(config)), noise_seed_(noise_seed), noise_(noise_seed) {
  int next = mode_state_ + 2 * static_cast<int>(config_.panel_modes.size());
  da_sections_ = converter_sections(config_.converters.da_filter, next);
  ad_sections_ = converter_sections(config_.converters.ad_filter, next);
  if (config_.creep.fraction > 0.0) creep_state_ = next++;
  if (config_.eddy.L2_H > 0.0) eddy_state_ = next++;
  for (Eigen::VectorXd* v : {&state_, &k1_, &k2_, &k3_, &k4_, &trial_}) v->setZero(next);
  delay_line_.assign(static_cast<std::size_t>(config_.converters.delay_samples), 0.0);
  if (config_.sensor.kind == SensorKind::microphone && config_.sensor.delay_samples > 0.0) {
    // Two more than the delay in integrator steps: the two steps the reading is interpolated between.
    const double steps = config_.sensor.delay_samples * config_.oversample;
    mic_line_.assign(static_cast<std::size_t>(std::floor(steps)) + 2, 0.0);
  }
  noise_sections_ = noise_sections<NoiseSection>(config_.sensor.coloured_noise, config_.fs);
}

void VirtualTransducer::reset() noexcept {
  state_.setZero();
  std::fill(delay_line_.begin(), delay_line_.end(), 0.0);
  delay_pos_ = 0;
  std::fill(mic_line_.begin(), mic_line_.end(), 0.0);
  mic_pos_ = 0;
  for (NoiseSection& s : noise_sections_) s.state = 0.0;
  noise_ = dsp::Rng(noise_seed_);
}

// The state's time derivative ds at state s for one drive sample (the DA filter, the coil with its eddy-current
// branch, the mechanics with creep, the panel modes, the AD filter), and in `sensed` what enters the AD filter:
// the sensor kind's quantity, the preamp's clip applied.
void VirtualTransducer::derivatives(const Eigen::VectorXd& s, double drive, Eigen::VectorXd& ds,
                                    double& sensed) const noexcept {
  const PlantConfig& c = config_;
  const NonlinearTerms& n = c.nonlinear;

  double u = converter_derivatives(da_sections_, s, drive, ds);
  if (const double g = n.clipping.gain(); g != 0.0) u += g * (soft_clip(u, n.clipping.level, n.clipping.knee) - u);
  const double volts = c.amplifier_gain_V * u + c.amplifier_offset_V;

  const double i = s[kCurrent], x = s[kDisplacement], v = s[kVelocity], temperature = s[kTemperature];
  const double xm = x * kMmPerM;

  // Large-signal element values (docs/transducer.md): polynomials in displacement (mm) and current.
  const double bl = c.Bl_Tm * (1.0 + n.force_factor.gain() * (n.force_factor.b1_per_mm * xm +
                                                               n.force_factor.b2_per_mm2 * xm * xm));
  double spring = c.stiffness_N_per_m * x *
                  (1.0 + n.stiffness.gain() * (n.stiffness.k1_per_mm * xm + n.stiffness.k2_per_mm2 * xm * xm));
  if (creep_state_ >= 0) {
    // Creep: F = K0·(x − c·z), τ·dz/dt = x − z (the share c of the spring relaxes).
    const double z = s[creep_state_];
    spring -= c.stiffness_N_per_m * c.creep.fraction * z;
    ds[creep_state_] = (x - z) / c.creep.time_constant_s;
  }
  const double gt = n.thermal.gain();
  const double re = c.Re_ohm * (1.0 + gt * n.thermal.alpha_per_K * temperature);
  const double gl = n.inductance.gain();
  // the floor: a share of Le0, and what the integrator can follow at its step with the coil's whole resistance
  const double step = 1.0 / (c.fs * c.oversample);
  const double coil_ohm = re + (eddy_state_ >= 0 ? c.eddy.R2_ohm : 0.0);
  const double le = std::max({c.Le_H * kMinInductanceFraction, kMinCoilTimeConstantSteps * step * coil_ohm,
                              c.Le_H * (1.0 + gl * (n.inductance.l1_per_mm * xm + n.inductance.l2_per_mm2 * xm * xm +
                                                    n.inductance.li2_per_A2 * i * i))});
  const double dle_dx = c.Le_H * gl * (n.inductance.l1_per_mm + 2.0 * n.inductance.l2_per_mm2 * xm) * kMmPerM;
  const double friction =
      n.friction.gain() * n.friction.coulomb_N * std::tanh(v / n.friction.velocity_scale_m_per_s);

  const double rm = c.damping_Ns_per_m * (1.0 + n.damping.gain() * n.damping.r2_per_m2ps2 * v * v);  // Rms(v)

  // Le·di/dt = u − Re·i − Bl·v − i·v·dLe/dx;  m·dv/dt = Bl·i + ½i²·dLe/dx − Rms(v)·v − K(x)·x − F_friction
  const double force = bl * i + 0.5 * i * i * dle_dx;
  ds[kCurrent] = (volts - re * i - bl * v - i * v * dle_dx) / le;
  if (eddy_state_ >= 0) {
    // The L2R2 branch in series: its voltage R2·(i − i₂) with L2·di₂/dt = R2·(i − i₂).
    const double branch_V = c.eddy.R2_ohm * (i - s[eddy_state_]);
    ds[kCurrent] -= branch_V / le;
    ds[eddy_state_] = branch_V / c.eddy.L2_H;
  }
  ds[kDisplacement] = v;
  ds[kVelocity] = (force - rm * v - spring - friction) / c.mass_kg;
  ds[kTemperature] =
      gt != 0.0 ? (re * i * i * n.thermal.resistance_K_per_W - temperature) / n.thermal.time_constant_s : 0.0;

  // Panel modes: q̈ + 2ζω·q̇ + ω²·q = g·F/m; each adds q̈ (q̇, q) to the measured acceleration (velocity,
  // displacement).
  const SensorKind kind = c.sensor.kind;
  const int order = kind == SensorKind::displacement ? 0 : kind == SensorKind::velocity ? 1 : 2;
  sensed = order == 2 ? ds[kVelocity] : order == 1 ? v : x;
  int p = mode_state_;
  for (const PanelMode& m : c.panel_modes) {
    const double w = 2.0 * std::numbers::pi * m.frequency_hz;
    ds[p] = s[p + 1];
    ds[p + 1] = m.gain * force / c.mass_kg - 2.0 * m.damping_ratio * w * s[p + 1] - w * w * s[p];
    sensed += order == 2 ? ds[p + 1] : order == 1 ? s[p + 1] : s[p];
    p += 2;
  }
  // The sensor's preamplifier saturates before the anti-alias filter: a static nonlinearity between two
  // filters (the mechanics and the AD filter), a Wiener–Hammerstein structure.
  const double clip_V = c.sensor.preamp_clip_V;
  if (clip_V > 0.0) {
    const double limit = clip_V / sensor_sensitivity(c.sensor);
    sensed = limit * std::tanh(sensed / limit);
  }
  converter_derivatives(ad_sections_, s, sensed, ds);
}

// What the AD converter holds now (before the sensor's scale): the AD filter's output, or without one the
// sensed quantity itself at this instant.
double VirtualTransducer::sensed_now(double drive) noexcept {
  if (!ad_sections_.empty()) return state_[ad_sections_.back().state];
  double sensed = 0.0;
  derivatives(state_, drive, k1_, sensed);
  return sensed;
}

// One sample of the coloured noise: the sum of its sections, each fed by its own white noise.
double VirtualTransducer::coloured_noise() noexcept {
  double sum = 0.0;
  for (NoiseSection& s : noise_sections_) {
    s.state = s.a * s.state + s.g * noise_.gaussian();
    sum += s.state;
  }
  return sum;
}

PlantSample VirtualTransducer::step(double drive) noexcept {
  if (!delay_line_.empty()) {
    std::swap(drive, delay_line_[delay_pos_]);
    delay_pos_ = (delay_pos_ + 1) % delay_line_.size();
  }
  const double h = 1.0 / (config_.fs * config_.oversample);
  double sensed = 0.0;
  for (int sub = 0; sub < config_.oversample; ++sub) {
    // Classic RK4 with the drive held constant over the step (zero-order hold is exact).
    derivatives(state_, drive, k1_, sensed);
    trial_.noalias() = state_ + 0.5 * h * k1_;
    derivatives(trial_, drive, k2_, sensed);
    trial_.noalias() = state_ + 0.5 * h * k2_;
    derivatives(trial_, drive, k3_, sensed);
    trial_.noalias() = state_ + h * k3_;
    derivatives(trial_, drive, k4_, sensed);
    state_.noalias() += (h / 6.0) * (k1_ + 2.0 * k2_ + 2.0 * k3_ + k4_);
    if (!mic_line_.empty()) {
      mic_pos_ = (mic_pos_ + 1) % mic_line_.size();
      mic_line_[mic_pos_] = sensed_now(drive);
    }
  }
  double measured;
  if (mic_line_.empty()) {
    measured = sensed_now(drive);  // at the sampling instant
  } else {
    // The reading delay·oversample integrator steps back, interpolated linearly between the two steps around it.
    const double steps = config_.sensor.delay_samples * config_.oversample;
    const auto whole = static_cast<std::size_t>(std::floor(steps));
    const double fraction = steps - static_cast<double>(whole);
    const std::size_t size = mic_line_.size();
    const double later = mic_line_[(mic_pos_ + size - whole) % size];
    const double earlier = mic_line_[(mic_pos_ + 2 * size - whole - 1) % size];
    measured = (1.0 - fraction) * later + fraction * earlier;
  }
  const Sensor& sensor = config_.sensor;
  PlantSample out;
  out.y_clean = sensor_sensitivity(sensor) * measured + sensor.offset_V;
  out.y = out.y_clean + (sensor.noise_rms_V > 0.0 ? sensor.noise_rms_V * noise_.gaussian() : 0.0);
  if (!noise_sections_.empty()) out.y += coloured_noise();
  out.i = state_[kCurrent];
  out.x = state_[kDisplacement];
  out.v = state_[kVelocity];
  return out;
}

PlantRecord simulate(const PlantConfig& config, const Eigen::VectorXd& drive, std::uint64_t noise_seed,
                     const ProgressCallback& progress) {
  VirtualTransducer plant(config, noise_seed);
  const Eigen::Index n = drive.size();
  PlantRecord r{Eigen::VectorXd(n), Eigen::VectorXd(n), Eigen::VectorXd(n), Eigen::VectorXd(n)};
  for (Eigen::Index k = 0; k < n; ++k) {
    if (!std::isfinite(drive[k])) {
      throw std::invalid_argument("drive sample " + std::to_string(k) + " is not finite");
    }
    const PlantSample s = plant.step(drive[k]);
    r.y[k] = s.y;
    r.i[k] = s.i;
    r.x[k] = s.x;
    r.v[k] = s.v;
    if (progress && (k + 1) % 8192 == 0) progress(static_cast<double>(k + 1) / static_cast<double>(n));
  }
  if (progress) progress(1.0);
  return r;
}

}  // namespace panelbass::models

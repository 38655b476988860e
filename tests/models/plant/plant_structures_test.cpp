// The virtual transducer's structures beyond the presets' (issues 56 and 58: a family whose structure differs
// from the models), each against an expectation computed apart from the simulator: the L2R2 branch's blocked
// impedance against its closed form, the velocity and displacement sensors against the integral of the
// accelerometer, the microphone's delay against the accelerometer's phase, the coloured noise's spectrum
// against its slope, and the ±20 % variants against their factors.

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <filesystem>
#include <numbers>
#include <string>

#include "dsp/excitation.h"
#include "dsp/spectrum.h"
#include "models/io/config_error.h"
#include "models/plant/plant_presets.h"
#include "models/plant/plant_variants.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::models {
namespace {

using cplx = std::complex<double>;
constexpr double kTwoPi = 2.0 * std::numbers::pi;

// The linear preset at 48 kHz, one integrator step per sample (the preset's own step), without sensor noise:
// fast enough that a trapezoid integral of the sampled accelerometer is accurate below 400 Hz.
PlantConfig fast_linear() {
  PlantConfig p = plant_preset("linear");
  p.fs = 48000.0;
  p.oversample = 1;
  p.converters.delay_samples = 0;
  p.sensor.noise_rms_V = 0.0;
  return p;
}

// Three sines below 400 Hz, from rest.
Eigen::VectorXd low_sines(Eigen::Index n, double fs) {
  Eigen::VectorXd u(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / fs;
    u[k] = 0.2 * std::sin(kTwoPi * 37.0 * t) + 0.15 * std::sin(kTwoPi * 110.0 * t + 1.0) +
           0.1 * std::sin(kTwoPi * 290.0 * t + 2.0);
  }
  return u;
}

// The cumulative trapezoid integral of x sampled at fs, from 0.
Eigen::VectorXd trapezoid(const Eigen::VectorXd& x, double fs) {
  Eigen::VectorXd out(x.size());
  double sum = 0.0, previous = 0.0;
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    sum += 0.5 * (x[k] + previous) / fs;
    previous = x[k];
    out[k] = sum;
  }
  return out;
}

double rms(const Eigen::VectorXd& x) { return std::sqrt(x.squaredNorm() / static_cast<double>(x.size())); }

// The complex amplitude at f of the last `n` samples of x (a whole number of periods), by least squares.
cplx phasor(const Eigen::VectorXd& x, double f, double fs, Eigen::Index n) {
  cplx sum = 0.0;
  const Eigen::Index start = x.size() - n;
  for (Eigen::Index k = start; k < x.size(); ++k) sum += x[k] * std::polar(1.0, -kTwoPi * f * static_cast<double>(k) / fs);
  return 2.0 * sum / static_cast<double>(n);
}

// ---------------------------------------------------------------------------------------------
// The eddy-current branch

// The coil's blocked impedance with the L2R2 branch: Re + jωLe + jωL2·R2/(R2 + jωL2).
cplx blocked_impedance(const PlantConfig& p, double w) {
  const cplx jw(0.0, w);
  return p.Re_ohm + jw * p.Le_H + jw * p.eddy.L2_H * p.eddy.R2_ohm / (p.eddy.R2_ohm + jw * p.eddy.L2_H);
}

// Current per drive at sample k from a sine e^{jωkT} held over each sample and read at the period's end: the held
// staircase carries every image ω + mωs with the hold's e^{−jΩT/2}·sinc(ΩT/2), each through the impedance, and all
// sampled at (k+1)T fold back onto ω: I/U = gain·e^{jωT}·Σ_m H_zoh(Ω_m)/Z(Ω_m).
cplx sampled_admittance(const PlantConfig& p, double f) {
  const double T = 1.0 / p.fs;
  cplx sum = 0.0;
  for (int m = -400; m <= 400; ++m) {
    const double w = kTwoPi * (f + m * p.fs);
    const cplx hold = std::polar(std::sin(w * T / 2.0) / (w * T / 2.0), -w * T / 2.0);
    sum += hold / blocked_impedance(p, w);
  }
  return p.amplifier_gain_V * std::polar(1.0, kTwoPi * f * T) * sum;
}

TEST(PlantStructures, EddyCurrentBranchGivesTheBlockedImpedanceOfItsClosedForm) {
  PlantConfig p = fast_linear();
  p.Bl_Tm = 1e-9;  // the mechanics blocked: no back-EMF
  p.panel_modes.clear();
  p.converters.da_filter.order = 0;
  p.converters.ad_filter.order = 0;
  p.amplifier_gain_V = 1.0;
  p.eddy = {5e-4, 3.0};
  p.oversample = 4;
  ASSERT_GE(p.oversample, required_oversample(p));
  const Eigen::Index n = 9600;  // 0.2 s; the last half is a whole number of periods of each frequency
  for (double f : {100.0, 1000.0, 4000.0}) {
    SCOPED_TRACE(f);
    const Eigen::VectorXd u = dsp::sine(static_cast<std::size_t>(n), p.fs, f, 0.5);
    const PlantRecord r = simulate(p, u, 1);
    const cplx measured = phasor(r.i, f, p.fs, n / 2) / phasor(u, f, p.fs, n / 2);
    const cplx expected = sampled_admittance(p, f);
    EXPECT_LT(std::abs(measured - expected), 1e-3 * std::abs(expected)) << measured << " vs " << expected;
    // The branch matters at this frequency: without it the admittance differs by far more than the tolerance.
    PlantConfig without = p;
    without.eddy.L2_H = 0.0;
    EXPECT_GT(std::abs(sampled_admittance(without, f) - expected), 0.02 * std::abs(expected));
  }
}

// ---------------------------------------------------------------------------------------------
// Other sensors

TEST(PlantStructures, VelocityAndDisplacementSensorsReadTheIntegralsOfTheAccelerometer) {
  PlantConfig acc = fast_linear();
  acc.sensor.sensitivity_V_per_mps2 = 0.002;
  acc.panel_modes = {{250.0, 0.05, 0.5}};  // a mode within the sines' band, so that its share of each reading counts
  PlantConfig vel = acc, disp = acc;
  vel.sensor.kind = SensorKind::velocity;
  vel.sensor.sensitivity_V_per_mps = 0.5;
  disp.sensor.kind = SensorKind::displacement;
  disp.sensor.sensitivity_V_per_m = 200.0;
  const Eigen::VectorXd u = low_sines(12000, acc.fs);
  const Eigen::VectorXd a = simulate(acc, u, 1).y / 0.002;
  const Eigen::VectorXd v = simulate(vel, u, 1).y / 0.5;
  const Eigen::VectorXd x = simulate(disp, u, 1).y / 200.0;
  const Eigen::VectorXd v_from_a = trapezoid(a, acc.fs);
  const Eigen::VectorXd x_from_a = trapezoid(v_from_a, acc.fs);
  EXPECT_LT(rms(v - v_from_a), 0.005 * rms(v));
  EXPECT_LT(rms(x - x_from_a), 0.01 * rms(x));
  // The panel mode is in every reading: without it the velocity sensor reads a different signal.
  PlantConfig no_mode = vel;
  no_mode.panel_modes.clear();
  EXPECT_GT(rms(simulate(no_mode, u, 1).y / 0.5 - v), 0.05 * rms(v));
  PlantConfig no_mode_x = disp;
  no_mode_x.panel_modes.clear();
  EXPECT_GT(rms(simulate(no_mode_x, u, 1).y / 200.0 - x), 0.05 * rms(x));
}

TEST(PlantStructures, MicrophoneIsTheAccelerometerDelayedByItsFractionalDelay) {
  PlantConfig acc = plant_preset("linear");
  acc.sensor.noise_rms_V = 0.0;
  PlantConfig mic = acc;
  mic.sensor.kind = SensorKind::microphone;
  mic.sensor.sensitivity_V_per_mps2 = 0.005;
  mic.sensor.delay_samples = 7.3;
  const Eigen::VectorXd u = dsp::uniform_noise(60000, 0.5, 3);
  const Eigen::VectorXd a = simulate(acc, u, 1).y / acc.sensor.sensitivity_V_per_mps2;
  const Eigen::VectorXd p = simulate(mic, u, 1).y / 0.005;
  // Cross-correlation: the peak at the whole samples of the delay.
  Eigen::Index best = 0;
  double peak = -1.0;
  for (Eigen::Index lag = 0; lag < 20; ++lag) {
    const double c = a.head(a.size() - 20).dot(p.segment(lag, a.size() - 20));
    if (c > peak) peak = c, best = lag;
  }
  EXPECT_EQ(best, 7);
  // The fraction from the phase of the cross-spectrum: −ω·d over the band the accelerometer carries (50-800 Hz).
  const dsp::FrequencyResponse h = dsp::h1_frf(a, p, acc.fs, {1024, 0.5, dsp::Window::hann});
  double num = 0.0, den = 0.0;
  for (Eigen::Index k = 0; k < h.frequency.size(); ++k) {
    const double f = h.frequency[k];
    if (f < 50.0 || f > 800.0) continue;
    const double w = kTwoPi * f / acc.fs;  // rad per sample
    // The phase unwrapped against the whole-sample part: arg(H·e^{jω·7}) = −ω·0.3.
    const double residual_phase = std::arg(h.h[k] * std::polar(1.0, 7.0 * w));
    num += w * -residual_phase;
    den += w * w;
    EXPECT_NEAR(std::abs(h.h[k]), 1.0, 0.01) << f << " Hz";
  }
  EXPECT_NEAR(7.0 + num / den, 7.3, 0.01);
}

// ---------------------------------------------------------------------------------------------
// Coloured sensor noise

// The least-squares slope of log10(PSD) against log10(f) over [lo, hi] Hz of the sensor's reading at rest.
struct NoiseMeasure {
  double slope = 0.0, rms = 0.0;
};
NoiseMeasure measure_noise(const PlantConfig& p, double lo, double hi, std::uint64_t seed) {
  const Eigen::VectorXd y = simulate(p, Eigen::VectorXd::Zero(300000), seed).y;
  const dsp::PowerSpectrum s = dsp::welch_psd(y, p.fs, {8192, 0.5, dsp::Window::hann});
  double sx = 0, sy = 0, sxx = 0, sxy = 0, count = 0;
  for (Eigen::Index k = 1; k < s.frequency.size(); ++k) {
    if (s.frequency[k] < lo || s.frequency[k] > hi) continue;
    const double lx = std::log10(s.frequency[k]), ly = std::log10(s.psd[k]);
    sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly, count += 1;
  }
  return {(count * sxy - sx * sy) / (count * sxx - sx * sx), rms(y)};
}

TEST(PlantStructures, ColouredNoiseHasTheSlopeAndLevelOfItsShape) {
  PlantConfig p = plant_preset("linear");
  p.sensor.noise_rms_V = 0.0;
  p.sensor.coloured_noise.rms_V = 0.05;
  p.sensor.coloured_noise.shape = NoiseShape::lowpass;
  p.sensor.coloured_noise.corner_hz = 5.0;
  // Far above its corner a first-order low-pass falls by 20 dB a decade: PSD ∝ f⁻².
  const NoiseMeasure lowpass = measure_noise(p, 50.0, 300.0, 4);
  EXPECT_NEAR(lowpass.slope, -2.0, 0.1);
  EXPECT_NEAR(lowpass.rms, 0.05, 0.1 * 0.05);  // a 5 Hz noise over 100 s: ~1000 independent stretches
  p.sensor.coloured_noise.shape = NoiseShape::pink;
  p.sensor.coloured_noise.low_hz = 1.0;
  p.sensor.coloured_noise.high_hz = 1500.0;
  // 1/f inside its band: PSD ∝ f⁻¹.
  const NoiseMeasure pink = measure_noise(p, 10.0, 500.0, 4);
  EXPECT_NEAR(pink.slope, -1.0, 0.1);
  EXPECT_NEAR(pink.rms, 0.05, 0.1 * 0.05);
  // A noise-free sensor reads nothing at rest, coloured noise included.
  EXPECT_EQ(simulate(without_sensor_noise(p), Eigen::VectorXd::Zero(1000), 4).y.cwiseAbs().maxCoeff(), 0.0);
  // Seeded: the same seed gives the same noise, another seed another one.
  EXPECT_EQ(measure_noise(p, 10.0, 500.0, 4).rms, pink.rms);
  EXPECT_NE(measure_noise(p, 10.0, 500.0, 5).rms, pink.rms);
}

// ---------------------------------------------------------------------------------------------
// The plant file

std::string plant_error(const nlohmann::json& j) {
  try {
    plant_from_json(j);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(PlantStructures, NewElementsGoThroughTheFileAndAreWrittenOnlyWhenUsed) {
  PlantConfig p = plant_preset("linear");
  p.eddy = {4e-4, 2.5};
  p.sensor.kind = SensorKind::microphone;
  p.sensor.sensitivity_V_per_mps2 = 0.004;
  p.sensor.delay_samples = 2.25;
  p.sensor.coloured_noise = {NoiseShape::pink, 0.01, 10.0, 2.0, 1000.0};
  p.oversample = required_oversample(p);
  const nlohmann::json j = plant_to_json(p);
  EXPECT_EQ(j["electrical"]["L2_H"], 4e-4);
  EXPECT_EQ(j["sensor"]["kind"], "microphone");
  EXPECT_EQ(j["sensor"]["delay_samples"], 2.25);
  EXPECT_EQ(j["sensor"]["coloured_noise"], nlohmann::json::parse(R"({"shape": "pink", "rms_V": 0.01, "low_hz": 2.0, "high_hz": 1000.0})"));
  const PlantConfig back = plant_from_json(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(back.eddy.L2_H, 4e-4);
  EXPECT_EQ(back.eddy.R2_ohm, 2.5);
  EXPECT_EQ(back.sensor.kind, SensorKind::microphone);
  EXPECT_EQ(back.sensor.delay_samples, 2.25);
  EXPECT_EQ(back.sensor.coloured_noise.shape, NoiseShape::pink);
  EXPECT_EQ(back.sensor.coloured_noise.high_hz, 1000.0);
  // A velocity sensor writes its own sensitivity, and none of the others.
  PlantConfig v = plant_preset("linear");
  v.sensor.kind = SensorKind::velocity;
  v.sensor.sensitivity_V_per_mps = 0.3;
  const nlohmann::json jv = plant_to_json(v);
  EXPECT_EQ(jv["sensor"]["sensitivity_V_per_mps"], 0.3);
  EXPECT_FALSE(jv["sensor"].contains("sensitivity_V_per_mps2"));
  EXPECT_EQ(plant_from_json(jv).sensor.sensitivity_V_per_mps, 0.3);
  // The presets write none of the new keys.
  const nlohmann::json preset = plant_to_json(plant_preset("panel-exciter"));
  EXPECT_FALSE(preset["electrical"].contains("L2_H"));
  EXPECT_FALSE(preset["sensor"].contains("kind"));
  EXPECT_FALSE(preset["sensor"].contains("coloured_noise"));
}

TEST(PlantStructures, BadNewKeysAreErrorsNamingTheirPath) {
  const nlohmann::json base = plant_to_json(plant_preset("linear"));
  auto with = [&](const std::string& pointer, const nlohmann::json& value) {
    nlohmann::json j = base;
    j[nlohmann::json::json_pointer(pointer)] = value;
    return plant_error(j);
  };
  EXPECT_NE(with("/sensor/kind", "laser").find("plant.sensor.kind: unknown sensor kind \"laser\""), std::string::npos);
  nlohmann::json velocity = base;
  velocity["sensor"]["kind"] = "velocity";  // still carries the accelerometer's sensitivity
  EXPECT_NE(plant_error(velocity).find("plant.sensor.sensitivity_V_per_mps2: not the sensitivity of a velocity sensor"),
            std::string::npos)
      << plant_error(velocity);
  EXPECT_NE(with("/sensor/delay_samples", 2.0).find("plant.sensor.delay_samples: only a microphone"), std::string::npos);
  EXPECT_NE(with("/electrical/L2_H", -1e-4).find("plant.electrical.L2_H"), std::string::npos);
  EXPECT_NE(with("/electrical/R2_ohm", 0.0).find("plant.electrical.R2_ohm"), std::string::npos);
  EXPECT_NE(with("/sensor/coloured_noise", nlohmann::json{{"shape", "brown"}}).find("plant.sensor.coloured_noise.shape"),
            std::string::npos);
  EXPECT_NE(with("/sensor/coloured_noise", nlohmann::json{{"corner_hz", 2000.0}, {"rms_V", 0.1}})
                .find("plant.sensor.coloured_noise.corner_hz"),
            std::string::npos);
  EXPECT_NE(with("/sensor/coloured_noise", nlohmann::json{{"shape", "pink"}, {"low_hz", 100.0}, {"high_hz", 50.0}})
                .find("plant.sensor.coloured_noise.high_hz"),
            std::string::npos);
  // A fast eddy branch needs a finer integrator step, and the error says how fine.
  EXPECT_NE(with("/electrical/L2_H", 1e-6).find("plant.oversample"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// The family (tests/support/plants)

// Every file of the family loads, is named after its file, and stays finite and within a few millimetres at the
// drive levels the control bench plays (a sine at 80 Hz and noise at 0.4), as do two ±20 % variants of it.
TEST(PlantStructures, EveryPlantOfTheFamilyLoadsAndSimulatesStablyAtDrive04) {
  const std::filesystem::path folder = std::filesystem::path(PANELBASS_SOURCE_DIR) / "tests/support/plants";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    if (entry.path().extension() != ".json") continue;
    ++files;
    SCOPED_TRACE(entry.path().filename().string());
    const PlantConfig p = load_plant_file(entry.path());
    EXPECT_EQ(p.name, entry.path().stem().string());
    Eigen::VectorXd u = dsp::uniform_noise(3000, 0.4, 1);
    u.head(1500) = dsp::sine(1500, p.fs, 80.0, 0.4);
    for (const PlantConfig& q : {p, varied_plant(p, 0.2, 1), varied_plant(p, 0.2, 2)}) {
      const PlantRecord r = simulate(q, u, 1);
      EXPECT_TRUE(r.y.allFinite() && r.i.allFinite()) << q.name;
      EXPECT_LT(r.x.cwiseAbs().maxCoeff(), 5e-3) << q.name;
    }
  }
  EXPECT_EQ(files, 15);
}

// ---------------------------------------------------------------------------------------------
// ±20 % variants

TEST(PlantStructures, VariantsMoveBlKLeAndFrictionByTheFractionInMixedDirections) {
  const PlantConfig panel = plant_preset("panel-exciter");
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    SCOPED_TRACE(seed);
    const VariantFactors f = variant_factors(0.2, seed);
    int up = 0;
    for (double factor : {f.force_factor, f.stiffness, f.inductance, f.friction}) {
      EXPECT_TRUE(std::abs(factor - 1.2) < 1e-15 || std::abs(factor - 0.8) < 1e-15) << factor;
      up += factor > 1.0;
    }
    EXPECT_GT(up, 0);
    EXPECT_LT(up, 4);
    const PlantConfig v = varied_plant(panel, 0.2, seed);
    EXPECT_EQ(v.Bl_Tm, panel.Bl_Tm * f.force_factor);
    EXPECT_EQ(v.stiffness_N_per_m, panel.stiffness_N_per_m * f.stiffness);
    EXPECT_EQ(v.Le_H, panel.Le_H * f.inductance);
    EXPECT_EQ(v.nonlinear.friction.coulomb_N, panel.nonlinear.friction.coulomb_N * f.friction);
    EXPECT_EQ(v.mass_kg, panel.mass_kg);
    EXPECT_EQ(v.Re_ohm, panel.Re_ohm);
    EXPECT_NO_THROW(plant_from_json(plant_to_json(v)));  // a valid plant file, integrator step included
    EXPECT_EQ(variant_factors(0.2, seed).stiffness, f.stiffness);  // the seed decides
  }
  EXPECT_EQ(varied_plant(panel, {1.2, 0.8, 1.2, 0.8}).name, "panel-exciter~Bl+20%,K-20%,Le+20%,friction-20%");
  EXPECT_THROW(variant_factors(0.0, 1), std::invalid_argument);
  EXPECT_THROW(variant_factors(1.5, 1), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

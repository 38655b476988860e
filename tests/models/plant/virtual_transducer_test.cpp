// The virtual transducer against independent expectations: the closed-form frequency response of the
// lumped model, RK4 convergence as the step halves, superposition, causality and determinism.

#include "models/plant/virtual_transducer.h"

#include <gtest/gtest.h>

#include <utility>
#include <vector>

#include <cmath>
#include <complex>
#include <numbers>

#include "dsp/excitation.h"
#include "models/plant/plant_presets.h"

namespace panelbass::models {
namespace {

using cd = std::complex<double>;
constexpr double kPi = std::numbers::pi;

PlantConfig quiet(PlantConfig c) {
  c.sensor.noise_rms_V = 0.0;
  return c;
}

// Analog Butterworth low-pass from its poles p_k = ωc·e^{jπ(2k+n−1)/(2n)}: H(s) = Π (−p_k)/(s − p_k).
cd butterworth(int order, double cutoff_hz, cd s) {
  cd h = 1.0;
  const double wc = 2.0 * kPi * cutoff_hz;
  for (int k = 1; k <= order; ++k) {
    const cd p = std::polar(wc, kPi * (2.0 * k + order - 1.0) / (2.0 * order));
    h *= -p / (s - p);
  }
  return h;
}

// Drive (dimensionless) to sensor volts of the linear lumped model of docs/transducer.md, in continuous time:
// i = V/(Ze + Bl²/Zm), v = Bl·i/Zm, a = s·v + Σ g_k·s²/(s² + 2ζω_k s + ω_k²)·Bl·i/m. With creep the spring is
// K(s) = K0·(1 − c/(1 + sτ)) (z = x/(1 + sτ) relaxes a share c of it).
cd continuous_response(const PlantConfig& c, double f) {
  const cd s(0.0, 2.0 * kPi * f);
  const cd ze = c.Re_ohm + s * c.Le_H;
  const cd spring = c.stiffness_N_per_m * (1.0 - c.creep.fraction / (1.0 + s * c.creep.time_constant_s));
  const cd zm = s * c.mass_kg + c.damping_Ns_per_m + spring / s;
  const cd i = c.amplifier_gain_V / (ze + c.Bl_Tm * c.Bl_Tm / zm);
  cd a = s * c.Bl_Tm * i / zm;
  for (const PanelMode& m : c.panel_modes) {
    const double w = 2.0 * kPi * m.frequency_hz;
    a += m.gain * s * s / (s * s + 2.0 * m.damping_ratio * w * s + w * w) * c.Bl_Tm * i / c.mass_kg;
  }
  return butterworth(c.converters.da_filter.order, c.converters.da_filter.cutoff_hz, s) * a *
         butterworth(c.converters.ad_filter.order, c.converters.ad_filter.cutoff_hz, s) *
         c.sensor.sensitivity_V_per_mps2;
}

// What the sampled plant should show at f: the zero-order hold's e^{−jωT/2}·sinc(ωT/2), the continuous
// response, sampling at the end of each period (e^{+jωT}) and the converter delay (e^{−jωdT}).
cd expected_discrete_response(const PlantConfig& c, double f) {
  const double wt = 2.0 * kPi * f / c.fs;
  const cd hold = std::polar(std::sin(wt / 2.0) / (wt / 2.0), -wt / 2.0);
  return hold * continuous_response(c, f) * std::polar(1.0, wt * (1.0 - c.converters.delay_samples));
}

cd single_bin(const Eigen::VectorXd& x, double f, double fs) {
  cd sum = 0.0;
  for (Eigen::Index k = 0; k < x.size(); ++k) sum += x[k] * std::polar(1.0, -2.0 * kPi * f * k / fs);
  return sum;
}

// The plant's response (output over drive, one bin) at each frequency, measured from a stepped sine of
// amplitude 0.5 that settles 3000 samples and measures 3000 at every step.
std::vector<std::pair<double, cd>> stepped_sine_response(const PlantConfig& plant, const std::vector<double>& frequencies) {
  dsp::SteppedSineSpec spec;
  spec.frequencies = frequencies;
  spec.fs = plant.fs;
  spec.amplitude = 0.5;
  spec.settle = 3000;  // the main resonance has decayed by > 100 dB
  spec.measure = 3000;
  const dsp::SteppedSine sine = dsp::stepped_sine(spec);
  const PlantRecord r = simulate(plant, sine.signal, 1);
  std::vector<std::pair<double, cd>> out;
  for (const dsp::SineStep& step : sine.steps) {
    const auto start = static_cast<Eigen::Index>(step.measure_start);
    const auto n = static_cast<Eigen::Index>(step.measure_length);
    out.emplace_back(step.frequency, single_bin(r.y.segment(start, n), step.frequency, plant.fs) /
                                         single_bin(sine.signal.segment(start, n), step.frequency, plant.fs));
  }
  return out;
}

TEST(VirtualTransducer, LinearPlantMatchesClosedFormFrequencyResponse) {
  const PlantConfig plant = quiet(plant_preset("linear"));
  for (const auto& [frequency, measured] : stepped_sine_response(plant, {30, 80, 150, 160, 300, 500, 800, 900, 1000, 1100})) {
    const cd expected = expected_discrete_response(plant, frequency);
    // Up to 800 Hz the converter images folded back by sampling are below −60 dB; near 1000 Hz the
    // image at fs − f passes both 4th-order filters at about −40 dB.
    const double tolerance_db = frequency <= 800 ? 0.02 : 0.15;
    EXPECT_NEAR(20 * std::log10(std::abs(measured)), 20 * std::log10(std::abs(expected)), tolerance_db)
        << "at " << frequency << " Hz";
    EXPECT_NEAR(std::arg(measured / expected), 0.0, tolerance_db / 8.7 * 2) << "at " << frequency << " Hz";
  }
}

// Creep (a viscoelastic suspension) softens the spring far below the resonance: the closed form with
// K(s) = K0·(1 − c/(1 + sτ)), and the displacement under a held drive settling at Bl·i/(K0·(1 − c)).
TEST(VirtualTransducer, CreepMatchesTheClosedFormOfARelaxingSpring) {
  PlantConfig plant = quiet(plant_preset("linear"));
  plant.creep.fraction = 0.3;
  plant.creep.time_constant_s = 0.01;
  for (const auto& [frequency, measured] : stepped_sine_response(plant, {10, 20, 40, 80, 150, 400}))
    EXPECT_NEAR(20 * std::log10(std::abs(measured / expected_discrete_response(plant, frequency))), 0.0, 0.02)
        << "at " << frequency << " Hz";
  const Eigen::VectorXd held = Eigen::VectorXd::Constant(6000, 0.1);  // 2 s: 200 time constants
  const PlantRecord still = simulate(plant, held, 1);
  const double current = 0.1 * plant.amplifier_gain_V / plant.Re_ohm;
  EXPECT_NEAR(still.x[held.size() - 1], plant.Bl_Tm * current / (plant.stiffness_N_per_m * (1.0 - 0.3)), 1e-9);
  // Without creep the same drive holds the displacement at Bl·i/K0.
  plant.creep.fraction = 0.0;
  EXPECT_NEAR(simulate(plant, held, 1).x[held.size() - 1], plant.Bl_Tm * current / plant.stiffness_N_per_m, 1e-9);
}

TEST(VirtualTransducer, Rk4ConvergesAtFourthOrderAsTheStepHalves) {
  PlantConfig plant = quiet(plant_preset("panel-exciter"));
  const Eigen::VectorXd u = dsp::uniform_noise(600, 1.0, 7);
  plant.oversample = 256;
  const Eigen::VectorXd reference = simulate(plant, u, 1).y;
  double previous_error = 0.0;
  for (int oversample : {8, 16, 32, 64}) {
    plant.oversample = oversample;
    const double error = (simulate(plant, u, 1).y - reference).cwiseAbs().maxCoeff() / reference.cwiseAbs().maxCoeff();
    if (previous_error > 0.0) {
      // Fourth order: 16× smaller per halving; allow a little for rounding.
      EXPECT_GT(previous_error / error, 12.0) << "oversample " << oversample;
    }
    previous_error = error;
    if (oversample == 16) {
      EXPECT_LT(error, 1e-4) << "the presets' oversample";
    }
  }
}

TEST(VirtualTransducer, ACoilWhoseInductanceCollapsesWithCurrentStaysFiniteAtFullScale) {
  // Le(i) = Le0·(1 − 0.08·i²) (tests/support/plants/panel-exciter-le-i.json) reaches its floor above 3.4 A, which a
  // 160 Hz drive of 0.8 or more gives; with the floor at 5 % of Le0 the coil's time constant was 0.18 of the RK4 step
  // (h·Re/Le = 5.6, past RK4's 2.785) and the current grew to NaN within 300 samples, never to come back. A coil of
  // resistance Re driven by at most gain_V volts carries at most gain_V/Re at DC and less at 160 Hz (its inductance
  // and back-EMF only take from it): the whole second of full scale stays finite and under 1.5·gain_V/Re.
  PlantConfig plant = quiet(plant_preset("panel-exciter"));
  plant.nonlinear.inductance.l1_per_mm = 0.0;
  plant.nonlinear.inductance.li2_per_A2 = -0.08;
  Eigen::VectorXd u(3000);
  for (Eigen::Index k = 0; k < u.size(); ++k) u[k] = std::sin(2.0 * kPi * 160.0 * k / plant.fs);
  const PlantRecord r = simulate(plant, u, 1);
  EXPECT_TRUE(r.y.allFinite() && r.i.allFinite() && r.x.allFinite());
  const double bound = 1.5 * plant.amplifier_gain_V / plant.Re_ohm;
  EXPECT_LT(r.i.cwiseAbs().maxCoeff(), bound);
  EXPECT_GT(r.i.cwiseAbs().maxCoeff(), 3.4);  // the floor was reached
}

TEST(VirtualTransducer, LinearPresetObeysSuperpositionAndPanelExciterDoesNot) {
  const Eigen::VectorXd u1 = dsp::uniform_noise(3000, 0.6, 1);
  const Eigen::VectorXd u2 = dsp::uniform_noise(3000, 0.4, 2);
  for (const char* name : {"linear", "panel-exciter"}) {
    const PlantConfig plant = quiet(plant_preset(name));
    const Eigen::VectorXd y_sum = simulate(plant, u1 + u2, 1).y;
    const Eigen::VectorXd y_parts = simulate(plant, u1, 1).y + simulate(plant, u2, 1).y;
    const double mismatch = (y_sum - y_parts).norm() / y_sum.norm();
    if (std::string(name) == "linear") {
      EXPECT_LT(mismatch, 1e-10);
    } else {
      EXPECT_GT(mismatch, 0.05);
    }
  }
}

TEST(VirtualTransducer, OutputIsCausalBehindTheConverterDelay) {
  PlantConfig plant = quiet(plant_preset("panel-exciter"));
  plant.converters.delay_samples = 3;
  Eigen::VectorXd u = Eigen::VectorXd::Zero(50);
  u[10] = 1.0;
  const PlantRecord r = simulate(plant, u, 1);
  // The drive of sample 10 reaches the coil 3 samples later and is first seen at the end of that sample.
  for (int k = 0; k < 13; ++k) EXPECT_EQ(r.y[k], 0.0) << k;
  EXPECT_NE(r.y[13], 0.0);
  EXPECT_NE(r.i[13], 0.0);
}

TEST(VirtualTransducer, SameSeedSameNoiseAndResetRestarts) {
  const PlantConfig plant = plant_preset("panel-exciter");
  const Eigen::VectorXd u = dsp::uniform_noise(500, 1.0, 3);
  EXPECT_EQ(simulate(plant, u, 5).y, simulate(plant, u, 5).y);
  EXPECT_NE(simulate(plant, u, 5).y, simulate(plant, u, 6).y);
  VirtualTransducer vt(plant, 5);
  Eigen::VectorXd first(500), second(500);
  for (int k = 0; k < 500; ++k) first[k] = vt.step(u[k]).y;
  vt.reset();
  for (int k = 0; k < 500; ++k) second[k] = vt.step(u[k]).y;
  EXPECT_EQ(first, second);
}

TEST(VirtualTransducer, SensorNoiseHasTheConfiguredLevel) {
  PlantConfig plant = plant_preset("linear");
  const Eigen::VectorXd u = Eigen::VectorXd::Zero(20000);
  const Eigen::VectorXd y = simulate(plant, u, 9).y;
  const double rms = std::sqrt(y.squaredNorm() / y.size());
  // RMS of 20000 Gaussian samples: relative standard error 1/√(2N) = 0.5 %.
  EXPECT_NEAR(rms, plant.sensor.noise_rms_V, 0.03 * plant.sensor.noise_rms_V);
  EXPECT_NEAR(y.mean(), 0.0, 5 * plant.sensor.noise_rms_V / std::sqrt(20000.0));
}

TEST(VirtualTransducer, TheCleanOutputIsTheSameTransducerReadByANoiseFreeSensor) {
  const PlantConfig plant = plant_preset("panel-exciter");
  const Eigen::VectorXd u = dsp::uniform_noise(20000, 0.8, 4);
  VirtualTransducer noisy(plant, 7), silent(quiet(plant), 7);
  Eigen::VectorXd noise(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    const PlantSample s = noisy.step(u[k]);
    const double reference = silent.step(u[k]).y;
    ASSERT_EQ(s.y_clean, reference) << "sample " << k << ": the noise must not reach the panel";
    noise[k] = s.y - s.y_clean;
  }
  // what separates the two is the sensor's noise: zero-mean, at its configured level (standard error 0.5 %)
  EXPECT_NEAR(std::sqrt(noise.squaredNorm() / noise.size()), plant.sensor.noise_rms_V, 0.03 * plant.sensor.noise_rms_V);
  EXPECT_NEAR(noise.mean(), 0.0, 5 * plant.sensor.noise_rms_V / std::sqrt(20000.0));
}

TEST(VirtualTransducer, ThermalCompressionLowersTheOutputOverTime) {
  PlantConfig plant = quiet(plant_preset("linear"));
  plant.nonlinear.thermal.enabled = true;
  plant.nonlinear.thermal.time_constant_s = 0.5;
  plant.nonlinear.thermal.resistance_K_per_W = 20.0;
  const Eigen::VectorXd u = dsp::sine(3000 * 4, plant.fs, 300.0, 0.8);
  const PlantRecord r = simulate(plant, u, 1);
  const auto rms_of = [&](Eigen::Index start) { return std::sqrt(r.i.segment(start, 3000).squaredNorm() / 3000); };
  // The coil heats with a 0.5 s time constant; the current, set by Re(T), falls as it does.
  EXPECT_LT(rms_of(9000), 0.97 * rms_of(300));
  plant.nonlinear.thermal.enabled = false;
  const PlantRecord cold = simulate(plant, u, 1);
  EXPECT_NEAR(std::sqrt(cold.i.segment(9000, 3000).squaredNorm() / 3000), std::sqrt(cold.i.segment(300, 3000).squaredNorm() / 3000), 1e-3);
}

// Rms(v) = Rm(1 + r2·v²) at the resonance, by the describing function of v³ (its fundamental is ¾V²·v): the
// plant with it moves like the linear plant whose resistance is Rm(1 + ¾·r2·V²), V the velocity amplitude.
TEST(VirtualTransducer, NonlinearDampingActsAsItsDescribingFunctionAtResonance) {
  PlantConfig plant = quiet(plant_preset("linear"));
  const double f0 = std::sqrt(plant.stiffness_N_per_m / plant.mass_kg) / (2.0 * kPi);
  const Eigen::VectorXd u = dsp::sine(6000, plant.fs, f0, 0.3);
  auto amplitude = [&](const PlantConfig& c) {
    const Eigen::VectorXd v = simulate(c, u, 1).v.tail(3000);
    return 2.0 * std::abs(single_bin(v, f0, plant.fs)) / 3000.0;
  };
  plant.nonlinear.damping.enabled = true;
  plant.nonlinear.damping.r2_per_m2ps2 = 0.0;
  const double linear = amplitude(plant);
  plant.nonlinear.damping.r2_per_m2ps2 = 0.6 / (linear * linear);  // ≈ 0.3 added at the linear amplitude
  const double damped = amplitude(plant);
  EXPECT_LT(damped, 0.95 * linear);
  PlantConfig equivalent = plant;
  equivalent.nonlinear.damping.enabled = false;
  equivalent.damping_Ns_per_m *= 1.0 + 0.75 * plant.nonlinear.damping.r2_per_m2ps2 * damped * damped;
  EXPECT_NEAR(damped, amplitude(equivalent), 0.02 * damped);
}

// The preamplifier's saturation lies before the AD filter: without one the measured signal never leaves
// ±preamp_clip_V, and far below the clip the plant is the linear one (tanh(x) = x − x³/3 + …).
TEST(VirtualTransducer, PreampSaturationBoundsTheSensorBeforeTheAdFilter) {
  PlantConfig plant = quiet(plant_preset("linear"));
  plant.converters.ad_filter.order = 0;
  const Eigen::VectorXd u = dsp::uniform_noise(6000, 1.0, 3);
  const double peak = simulate(plant, u, 1).y.cwiseAbs().maxCoeff();
  plant.sensor.preamp_clip_V = 0.5 * peak;
  EXPECT_LE(simulate(plant, u, 1).y.cwiseAbs().maxCoeff(), 0.5 * peak * (1.0 + 1e-12));
  const Eigen::VectorXd small = 0.01 * u;
  PlantConfig off = plant;
  off.sensor.preamp_clip_V = 0.0;
  const Eigen::VectorXd y_lin = simulate(off, small, 1).y;
  EXPECT_LT((simulate(plant, small, 1).y - y_lin).cwiseAbs().maxCoeff(), 1e-3 * y_lin.cwiseAbs().maxCoeff());
}

TEST(VirtualTransducer, RejectsNonFiniteDrive) {
  Eigen::VectorXd u = Eigen::VectorXd::Zero(10);
  u[4] = std::nan("");
  try {
    simulate(plant_preset("linear"), u, 1);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "drive sample 4 is not finite");
  }
}

}  // namespace
}  // namespace panelbass::models

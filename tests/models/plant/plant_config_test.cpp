// Plant configuration files: plant_from_json / plant_to_json / load_plant_file / linearized, the
// presets, and one bad-input test per failure mode of the validating loader. Every expectation below
// is written out by hand (the preset's values, the defaults of plant_config.h, the exact messages the
// loader documents), never computed by the code under test.

#include "models/plant/plant_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <regex>
#include <string>

#include "models/io/config_error.h"
#include "models/plant/plant_presets.h"
#include "tests/support/expect_error.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::models {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The panel-exciter preset as its documentation states it (plant_presets.cpp, after Moonen ch. 3):
// every field written out, so it is also exactly what plant_to_json must produce for that preset.
const char* const kPanelExciterJson = R"json({
  "format": "panelbass.plant/1",
  "name": "panel-exciter",
  "fs": 3000,
  "oversample": 16,
  "amplifier": {"gain_V": 20.0, "offset_V": 0.0},
  "electrical": {"Re_ohm": 4.0, "Le_H": 0.0003},
  "mechanical": {"mass_kg": 0.01, "stiffness_N_per_m": 8880, "damping_Ns_per_m": 0.4, "Bl_Tm": 1.5},
  "nonlinear": {
    "stiffness":    {"enabled": true, "scale": 1.0, "k1_per_mm": 0.03, "k2_per_mm2": 0.06},
    "force_factor": {"enabled": true, "scale": 1.0, "b1_per_mm": 0.0, "b2_per_mm2": -0.45},
    "inductance":   {"enabled": true, "scale": 1.0, "l1_per_mm": -0.1, "l2_per_mm2": 0.0, "li2_per_A2": -0.02},
    "friction":     {"enabled": true, "scale": 1.0, "coulomb_N": 0.05, "velocity_scale_m_per_s": 0.05},
    "clipping":     {"enabled": true, "scale": 1.0, "level": 0.7, "knee": 0.1},
    "thermal":      {"enabled": false, "scale": 1.0, "alpha_per_K": 0.00393, "resistance_K_per_W": 10.0,
                     "time_constant_s": 2.0}
  },
  "panel_modes": [{"frequency_hz": 1000.0, "damping_ratio": 0.03, "gain": 0.2346}],
  "converters": {
    "da_filter": {"order": 4, "cutoff_hz": 1200.0},
    "ad_filter": {"order": 4, "cutoff_hz": 1200.0},
    "delay_samples": 1
  },
  "sensor": {"sensitivity_V_per_mps2": 0.002, "offset_V": 0.0, "noise_rms_V": 0.07}
})json";

json panel_exciter_json() { return json::parse(kPanelExciterJson); }

// The linear preset: the panel exciter with every nonlinear switch off (scales and coefficients kept).
json linear_json() {
  json j = panel_exciter_json();
  j["name"] = "linear";
  for (auto& term : j["nonlinear"].items()) term.value()["enabled"] = false;
  return j;
}

/// EXPECT that `actual` equals `expected` as JSON (numbers by value), showing the difference.
void expect_json_equal(const json& actual, const json& expected) {
  EXPECT_EQ(actual, expected) << "patch from expected to actual: " << json::diff(expected, actual).dump(2);
}

void expect_switch(const NonlinearSwitch& a, const NonlinearSwitch& b, const std::string& what) {
  EXPECT_EQ(a.enabled, b.enabled) << what << ".enabled";
  EXPECT_EQ(a.scale, b.scale) << what << ".scale";
}

void expect_filter(const AnalogFilter& a, const AnalogFilter& b, const std::string& what) {
  EXPECT_EQ(a.order, b.order) << what << ".order";
  EXPECT_EQ(a.cutoff_hz, b.cutoff_hz) << what << ".cutoff_hz";
}

/// EXPECT that two configurations agree in every field, bit for bit.
void expect_same_plant(const PlantConfig& a, const PlantConfig& b) {
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.fs, b.fs);
  EXPECT_EQ(a.oversample, b.oversample);
  EXPECT_EQ(a.amplifier_gain_V, b.amplifier_gain_V);
  EXPECT_EQ(a.amplifier_offset_V, b.amplifier_offset_V);
  EXPECT_EQ(a.Re_ohm, b.Re_ohm);
  EXPECT_EQ(a.Le_H, b.Le_H);
  EXPECT_EQ(a.mass_kg, b.mass_kg);
  EXPECT_EQ(a.stiffness_N_per_m, b.stiffness_N_per_m);
  EXPECT_EQ(a.damping_Ns_per_m, b.damping_Ns_per_m);
  EXPECT_EQ(a.Bl_Tm, b.Bl_Tm);

  const NonlinearTerms& n = a.nonlinear;
  const NonlinearTerms& m = b.nonlinear;
  expect_switch(n.stiffness, m.stiffness, "stiffness");
  EXPECT_EQ(n.stiffness.k1_per_mm, m.stiffness.k1_per_mm);
  EXPECT_EQ(n.stiffness.k2_per_mm2, m.stiffness.k2_per_mm2);
  expect_switch(n.force_factor, m.force_factor, "force_factor");
  EXPECT_EQ(n.force_factor.b1_per_mm, m.force_factor.b1_per_mm);
  EXPECT_EQ(n.force_factor.b2_per_mm2, m.force_factor.b2_per_mm2);
  expect_switch(n.inductance, m.inductance, "inductance");
  EXPECT_EQ(n.inductance.l1_per_mm, m.inductance.l1_per_mm);
  EXPECT_EQ(n.inductance.l2_per_mm2, m.inductance.l2_per_mm2);
  EXPECT_EQ(n.inductance.li2_per_A2, m.inductance.li2_per_A2);
  expect_switch(n.friction, m.friction, "friction");
  EXPECT_EQ(n.friction.coulomb_N, m.friction.coulomb_N);
  EXPECT_EQ(n.friction.velocity_scale_m_per_s, m.friction.velocity_scale_m_per_s);
  expect_switch(n.clipping, m.clipping, "clipping");
  EXPECT_EQ(n.clipping.level, m.clipping.level);
  EXPECT_EQ(n.clipping.knee, m.clipping.knee);
  expect_switch(n.thermal, m.thermal, "thermal");
  EXPECT_EQ(n.thermal.alpha_per_K, m.thermal.alpha_per_K);
  EXPECT_EQ(n.thermal.resistance_K_per_W, m.thermal.resistance_K_per_W);
  EXPECT_EQ(n.thermal.time_constant_s, m.thermal.time_constant_s);

  ASSERT_EQ(a.panel_modes.size(), b.panel_modes.size());
  for (std::size_t k = 0; k < a.panel_modes.size(); ++k) {
    EXPECT_EQ(a.panel_modes[k].frequency_hz, b.panel_modes[k].frequency_hz) << "mode " << k;
    EXPECT_EQ(a.panel_modes[k].damping_ratio, b.panel_modes[k].damping_ratio) << "mode " << k;
    EXPECT_EQ(a.panel_modes[k].gain, b.panel_modes[k].gain) << "mode " << k;
  }

  expect_filter(a.converters.da_filter, b.converters.da_filter, "da_filter");
  expect_filter(a.converters.ad_filter, b.converters.ad_filter, "ad_filter");
  EXPECT_EQ(a.converters.delay_samples, b.converters.delay_samples);

  EXPECT_EQ(a.sensor.sensitivity_V_per_mps2, b.sensor.sensitivity_V_per_mps2);
  EXPECT_EQ(a.sensor.offset_V, b.sensor.offset_V);
  EXPECT_EQ(a.sensor.noise_rms_V, b.sensor.noise_rms_V);
}

/// A valid configuration in which every field differs from its default and from the presets, with
/// values (0.1, 1/3, …) that have no short binary form, so a lossy round trip would show.
PlantConfig unusual_plant() {
  PlantConfig c;
  c.name = "round-trip";
  c.fs = 4000.0;
  c.oversample = 20;
  c.amplifier_gain_V = 12.5;
  c.amplifier_offset_V = 0.1;
  c.Re_ohm = 3.3;
  c.Le_H = 2.5e-4;  // Re/Le = 13200 1/s, the fastest rate; 13200 / 80000 = 0.165 per step
  c.mass_kg = 0.02;
  c.stiffness_N_per_m = 1.1e4;
  c.damping_Ns_per_m = 0.7;
  c.Bl_Tm = 2.2;
  NonlinearTerms& n = c.nonlinear;
  n.stiffness.enabled = true;
  n.stiffness.scale = 0.5;
  n.stiffness.k1_per_mm = 0.01;
  n.stiffness.k2_per_mm2 = 1.0 / 3.0;
  n.force_factor.enabled = false;
  n.force_factor.scale = 1.5;
  n.force_factor.b1_per_mm = 0.03;
  n.force_factor.b2_per_mm2 = -0.3;
  n.inductance.enabled = true;
  n.inductance.scale = 2.0;
  n.inductance.l1_per_mm = -0.05;
  n.inductance.l2_per_mm2 = 0.01;
  n.inductance.li2_per_A2 = -0.03;
  n.friction.enabled = true;
  n.friction.scale = 0.75;
  n.friction.coulomb_N = 0.02;
  n.friction.velocity_scale_m_per_s = 2e-3;
  n.clipping.enabled = true;
  n.clipping.scale = 1.25;
  n.clipping.level = 0.8;
  n.clipping.knee = 0.2;
  n.thermal.enabled = true;
  n.thermal.scale = 0.9;
  n.thermal.alpha_per_K = 0.004;
  n.thermal.resistance_K_per_W = 12.0;
  n.thermal.time_constant_s = 3.5;
  c.panel_modes = {{800.0, 0.04, 0.1}, {1700.5, 0.01, -0.05}};
  c.converters.da_filter = {2, 1500.0};
  c.converters.ad_filter = {6, 1600.0};
  c.converters.delay_samples = 3;
  c.sensor.sensitivity_V_per_mps2 = 0.005;
  c.sensor.offset_V = 0.01;
  c.sensor.noise_rms_V = 0.03;
  return c;
}

/// The ConfigError message of `action`; fails the test if none is thrown or it is not one line.
template <class Action>
std::string config_error(Action action) {
  return testing_support::one_line_error<ConfigError>(action);
}

std::string parse_error(const json& j) {
  return config_error([&] { plant_from_json(j); });
}

// ---------------------------------------------------------------------------------------------
// Round trips and presets

TEST(PlantConfigRoundTrip, PanelExciterJsonComesBackFieldForField) {
  expect_json_equal(plant_to_json(plant_from_json(panel_exciter_json())), panel_exciter_json());
}

TEST(PlantConfigRoundTrip, LinearJsonComesBackFieldForField) {
  expect_json_equal(plant_to_json(plant_from_json(linear_json())), linear_json());
}

TEST(PlantConfigRoundTrip, PresetsWriteTheirDocumentedJson) {
  expect_json_equal(plant_to_json(plant_preset("panel-exciter")), panel_exciter_json());
  expect_json_equal(plant_to_json(plant_preset("linear")), linear_json());
}

TEST(PlantConfigRoundTrip, ConfigThroughJsonIsUnchanged) {
  for (const PlantConfig& c : {unusual_plant(), plant_preset("panel-exciter"), plant_preset("linear"), PlantConfig{}}) {
    SCOPED_TRACE(c.name);
    expect_same_plant(plant_from_json(plant_to_json(c)), c);
  }
}

TEST(PlantConfigRoundTrip, ConfigThroughJsonTextIsBitExact) {
  const PlantConfig c = unusual_plant();
  expect_same_plant(plant_from_json(json::parse(plant_to_json(c).dump())), c);
}

// The nonlinear damping and the preamplifier's saturation are written when used, and come back as written.
TEST(PlantConfigRoundTrip, DampingAndPreampSaturationAreWrittenWhenUsed) {
  PlantConfig c = unusual_plant();
  EXPECT_FALSE(plant_to_json(c)["nonlinear"].contains("damping"));
  EXPECT_FALSE(plant_to_json(c)["sensor"].contains("preamp_clip_V"));
  c.nonlinear.damping.enabled = true;
  c.nonlinear.damping.scale = 0.5;
  c.nonlinear.damping.r2_per_m2ps2 = 2.5;
  c.sensor.preamp_clip_V = 1.75;
  const json j = plant_to_json(c);
  EXPECT_EQ(j["nonlinear"]["damping"], json::parse(R"({"enabled": true, "scale": 0.5, "r2_per_m2ps2": 2.5})"));
  EXPECT_EQ(j["sensor"]["preamp_clip_V"], 1.75);
  const PlantConfig back = plant_from_json(json::parse(j.dump()));
  EXPECT_TRUE(back.nonlinear.damping.enabled);
  EXPECT_EQ(back.nonlinear.damping.scale, 0.5);
  EXPECT_EQ(back.nonlinear.damping.r2_per_m2ps2, 2.5);
  EXPECT_EQ(back.sensor.preamp_clip_V, 1.75);
}

// Creep is written when used (under "mechanical"), comes back as written, and is refused out of range.
TEST(PlantConfigRoundTrip, CreepIsWrittenWhenUsed) {
  PlantConfig c = unusual_plant();
  EXPECT_FALSE(plant_to_json(c)["mechanical"].contains("creep"));
  c.creep.fraction = 0.25;
  c.creep.time_constant_s = 0.02;
  const json j = plant_to_json(c);
  EXPECT_EQ(j["mechanical"]["creep"], json::parse(R"({"fraction": 0.25, "time_constant_s": 0.02})"));
  const PlantConfig back = plant_from_json(json::parse(j.dump()));
  EXPECT_EQ(back.creep.fraction, 0.25);
  EXPECT_EQ(back.creep.time_constant_s, 0.02);
  json bad = j;
  bad["mechanical"]["creep"]["fraction"] = 1.5;
  EXPECT_NE(parse_error(bad).find("plant.mechanical.creep.fraction"), std::string::npos) << parse_error(bad);
}

TEST(PlantConfigRoundTrip, JsonWritesEveryFieldOfTheUnusualPlant) {
  const json expected = json::parse(R"json({
    "format": "panelbass.plant/1", "name": "round-trip", "fs": 4000, "oversample": 20,
    "amplifier": {"gain_V": 12.5, "offset_V": 0.1},
    "electrical": {"Re_ohm": 3.3, "Le_H": 0.00025},
    "mechanical": {"mass_kg": 0.02, "stiffness_N_per_m": 11000, "damping_Ns_per_m": 0.7, "Bl_Tm": 2.2},
    "nonlinear": {
      "stiffness":    {"enabled": true, "scale": 0.5, "k1_per_mm": 0.01, "k2_per_mm2": 0.3333333333333333},
      "force_factor": {"enabled": false, "scale": 1.5, "b1_per_mm": 0.03, "b2_per_mm2": -0.3},
      "inductance":   {"enabled": true, "scale": 2.0, "l1_per_mm": -0.05, "l2_per_mm2": 0.01, "li2_per_A2": -0.03},
      "friction":     {"enabled": true, "scale": 0.75, "coulomb_N": 0.02, "velocity_scale_m_per_s": 0.002},
      "clipping":     {"enabled": true, "scale": 1.25, "level": 0.8, "knee": 0.2},
      "thermal":      {"enabled": true, "scale": 0.9, "alpha_per_K": 0.004, "resistance_K_per_W": 12.0,
                       "time_constant_s": 3.5}
    },
    "panel_modes": [{"frequency_hz": 800, "damping_ratio": 0.04, "gain": 0.1},
                    {"frequency_hz": 1700.5, "damping_ratio": 0.01, "gain": -0.05}],
    "converters": {"da_filter": {"order": 2, "cutoff_hz": 1500}, "ad_filter": {"order": 6, "cutoff_hz": 1600},
                   "delay_samples": 3},
    "sensor": {"sensitivity_V_per_mps2": 0.005, "offset_V": 0.01, "noise_rms_V": 0.03}
  })json");
  expect_json_equal(plant_to_json(unusual_plant()), expected);
}

TEST(PlantConfigPresets, LinearIsPanelExciterWithEveryNonlinearTermOff) {
  const PlantConfig linear = plant_preset("linear");
  const NonlinearTerms& n = linear.nonlinear;
  for (const NonlinearSwitch* s : {static_cast<const NonlinearSwitch*>(&n.stiffness),
                                   static_cast<const NonlinearSwitch*>(&n.force_factor),
                                   static_cast<const NonlinearSwitch*>(&n.inductance),
                                   static_cast<const NonlinearSwitch*>(&n.friction),
                                   static_cast<const NonlinearSwitch*>(&n.clipping),
                                   static_cast<const NonlinearSwitch*>(&n.thermal)}) {
    EXPECT_FALSE(s->enabled);
    EXPECT_EQ(s->gain(), 0.0);
  }
  // Everything else is the panel exciter's, switched off by hand here (not through linearized()).
  PlantConfig expected = plant_preset("panel-exciter");
  expected.name = "linear";
  expected.nonlinear.stiffness.enabled = false;
  expected.nonlinear.force_factor.enabled = false;
  expected.nonlinear.inductance.enabled = false;
  expected.nonlinear.friction.enabled = false;
  expected.nonlinear.clipping.enabled = false;
  expected.nonlinear.thermal.enabled = false;
  expect_same_plant(linear, expected);
}

TEST(PlantConfigPresets, PanelExciterHasItsNonlinearTermsOn) {
  const NonlinearTerms& n = plant_preset("panel-exciter").nonlinear;
  EXPECT_TRUE(n.stiffness.enabled);
  EXPECT_TRUE(n.force_factor.enabled);
  EXPECT_TRUE(n.inductance.enabled);
  EXPECT_TRUE(n.friction.enabled);
  EXPECT_TRUE(n.clipping.enabled);
  EXPECT_FALSE(n.thermal.enabled);
  EXPECT_EQ(n.clipping.gain(), 1.0);
}

TEST(PlantConfigPresets, LinearizedTurnsOffOnlyTheSwitches) {
  const PlantConfig original = unusual_plant();
  const PlantConfig linear = linearized(original);
  PlantConfig expected = unusual_plant();
  expected.nonlinear.stiffness.enabled = false;
  expected.nonlinear.inductance.enabled = false;
  expected.nonlinear.friction.enabled = false;
  expected.nonlinear.clipping.enabled = false;
  expected.nonlinear.thermal.enabled = false;
  expect_same_plant(linear, expected);
  expect_same_plant(original, unusual_plant());  // taken by value: the argument is untouched
}

TEST(PlantConfigPresets, EnabledTermsAreTheSwitchesThatAreOn) {
  // unusual_plant() has every term on but the force factor.
  EXPECT_EQ(enabled_nonlinear_terms(unusual_plant()),
            (std::vector<std::string>{"stiffness", "inductance", "friction", "clipping", "thermal"}));
  EXPECT_TRUE(enabled_nonlinear_terms(plant_preset("linear")).empty());
}

TEST(PlantConfigPresets, WithOnlyTermKeepsThatTermAndSwitchesOffTheRest) {
  const PlantConfig only = with_only_term(unusual_plant(), "friction");
  PlantConfig expected = unusual_plant();
  expected.nonlinear.stiffness.enabled = false;
  expected.nonlinear.inductance.enabled = false;
  expected.nonlinear.clipping.enabled = false;
  expected.nonlinear.thermal.enabled = false;
  expect_same_plant(only, expected);
  EXPECT_EQ(enabled_nonlinear_terms(only), std::vector<std::string>{"friction"});
  // A term that is off stays off: the plant is then linear.
  EXPECT_TRUE(enabled_nonlinear_terms(with_only_term(unusual_plant(), "force_factor")).empty());
  try {
    with_only_term(unusual_plant(), "hysteresis");
    ADD_FAILURE() << "an unknown term was accepted";
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(),
                 "unknown nonlinear term \"hysteresis\" (terms: stiffness, force_factor, inductance, friction, "
                 "clipping, thermal, damping)");
  }
}

TEST(PlantConfigPresets, NamesAreTheTwoPresets) {
  EXPECT_EQ(plant_preset_names(), (std::vector<std::string>{"panel-exciter", "linear"}));
  for (const std::string& name : plant_preset_names()) EXPECT_EQ(plant_preset(name).name, name);
}

TEST(PlantConfigPresets, UnknownNameListsThePresets) {
  const std::string message = config_error([] { plant_preset("nosuch"); });
  EXPECT_NE(message.find("\"nosuch\""), std::string::npos) << message;
  EXPECT_NE(message.find("panel-exciter"), std::string::npos) << message;
  EXPECT_NE(message.find("linear"), std::string::npos) << message;
  EXPECT_NE(message.find(".json"), std::string::npos) << message;  // says a file would do too
}

// ---------------------------------------------------------------------------------------------
// Defaults

TEST(PlantConfigDefaults, EmptyObjectGivesTheDocumentedDefaults) {
  const PlantConfig c = plant_from_json(json::object());
  // The defaults as plant_config.h documents them.
  EXPECT_EQ(c.name, "custom");
  EXPECT_EQ(c.fs, 3000.0);
  EXPECT_EQ(c.oversample, 16);
  EXPECT_EQ(c.amplifier_gain_V, 10.0);
  EXPECT_EQ(c.amplifier_offset_V, 0.0);
  EXPECT_EQ(c.Re_ohm, 4.0);
  EXPECT_EQ(c.Le_H, 3e-4);
  EXPECT_EQ(c.mass_kg, 0.05);
  EXPECT_EQ(c.stiffness_N_per_m, 4.4e4);
  EXPECT_EQ(c.damping_Ns_per_m, 8.0);
  EXPECT_EQ(c.Bl_Tm, 3.0);
  const NonlinearTerms& n = c.nonlinear;
  for (const NonlinearSwitch* s : {static_cast<const NonlinearSwitch*>(&n.stiffness),
                                   static_cast<const NonlinearSwitch*>(&n.force_factor),
                                   static_cast<const NonlinearSwitch*>(&n.inductance),
                                   static_cast<const NonlinearSwitch*>(&n.friction),
                                   static_cast<const NonlinearSwitch*>(&n.clipping),
                                   static_cast<const NonlinearSwitch*>(&n.thermal)}) {
    EXPECT_FALSE(s->enabled);
    EXPECT_EQ(s->scale, 1.0);
  }
  EXPECT_EQ(n.stiffness.k1_per_mm, 0.0);
  EXPECT_EQ(n.stiffness.k2_per_mm2, 0.0);
  EXPECT_EQ(n.force_factor.b1_per_mm, 0.0);
  EXPECT_EQ(n.force_factor.b2_per_mm2, 0.0);
  EXPECT_EQ(n.inductance.l1_per_mm, 0.0);
  EXPECT_EQ(n.inductance.l2_per_mm2, 0.0);
  EXPECT_EQ(n.inductance.li2_per_A2, 0.0);
  EXPECT_EQ(n.friction.coulomb_N, 0.0);
  EXPECT_EQ(n.friction.velocity_scale_m_per_s, 0.05);
  EXPECT_EQ(n.clipping.level, 1.0);
  EXPECT_EQ(n.clipping.knee, 0.05);
  EXPECT_EQ(n.thermal.alpha_per_K, 0.00393);
  EXPECT_EQ(n.thermal.resistance_K_per_W, 10.0);
  EXPECT_EQ(n.thermal.time_constant_s, 2.0);
  EXPECT_TRUE(c.panel_modes.empty());
  EXPECT_EQ(c.converters.da_filter.order, 4);
  EXPECT_EQ(c.converters.da_filter.cutoff_hz, 1200.0);
  EXPECT_EQ(c.converters.ad_filter.order, 4);
  EXPECT_EQ(c.converters.ad_filter.cutoff_hz, 1200.0);
  EXPECT_EQ(c.converters.delay_samples, 1);
  EXPECT_EQ(c.sensor.sensitivity_V_per_mps2, 0.01);
  EXPECT_EQ(c.sensor.offset_V, 0.0);
  EXPECT_EQ(c.sensor.noise_rms_V, 0.0);
}

TEST(PlantConfigDefaults, EmptySectionsKeepTheDefaults) {
  const json j = json::parse(R"({"format": "panelbass.plant/1", "amplifier": {}, "electrical": {},
    "mechanical": {}, "nonlinear": {"stiffness": {}, "clipping": {}}, "panel_modes": [],
    "converters": {"da_filter": {}}, "sensor": {}})");
  expect_same_plant(plant_from_json(j), PlantConfig{});
}

TEST(PlantConfigDefaults, PartialSectionChangesOnlyItsKeys) {
  const PlantConfig c = plant_from_json(json::parse(R"({"mechanical": {"mass_kg": 0.02}})"));
  PlantConfig expected;
  expected.mass_kg = 0.02;
  expect_same_plant(c, expected);
}

// ---------------------------------------------------------------------------------------------
// One test per failure mode; each message names the exact key path.

TEST(PlantConfigErrors, NotAnObject) {
  EXPECT_EQ(parse_error(json::array()), "plant: expected an object, got array");
}

TEST(PlantConfigErrors, UnknownTopLevelKey) {
  EXPECT_EQ(parse_error(json::parse(R"({"fss": 3000})")), "plant.fss: unknown key");
}

TEST(PlantConfigErrors, UnknownNestedKey) {
  json j = panel_exciter_json();
  j["mechanical"]["masss_kg"] = 0.01;
  EXPECT_EQ(parse_error(j), "plant.mechanical.masss_kg: unknown key");
}

TEST(PlantConfigErrors, UnknownKeyInANonlinearTerm) {
  json j = panel_exciter_json();
  j["nonlinear"]["stiffness"]["k3_per_mm3"] = 0.1;
  EXPECT_EQ(parse_error(j), "plant.nonlinear.stiffness.k3_per_mm3: unknown key");
}

TEST(PlantConfigErrors, UnknownNonlinearTerm) {
  json j = panel_exciter_json();
  j["nonlinear"]["creep"] = {{"enabled", true}};
  EXPECT_EQ(parse_error(j), "plant.nonlinear.creep: unknown key");
}

TEST(PlantConfigErrors, UnknownKeyInAPanelMode) {
  json j = panel_exciter_json();
  j["panel_modes"][0]["q"] = 10;
  EXPECT_EQ(parse_error(j), "plant.panel_modes[0].q: unknown key");
}

TEST(PlantConfigErrors, UnknownKeyInAFilter) {
  json j = panel_exciter_json();
  j["converters"]["ad_filter"]["type"] = "bessel";
  EXPECT_EQ(parse_error(j), "plant.converters.ad_filter.type: unknown key");
}

TEST(PlantConfigErrors, StringForANumber) {
  json j = panel_exciter_json();
  j["mechanical"]["mass_kg"] = "0.01";
  EXPECT_EQ(parse_error(j), "plant.mechanical.mass_kg: expected a number, got string");
}

TEST(PlantConfigErrors, NumberForABool) {
  json j = panel_exciter_json();
  j["nonlinear"]["friction"]["enabled"] = 1;
  EXPECT_EQ(parse_error(j), "plant.nonlinear.friction.enabled: expected true or false, got number");
}

TEST(PlantConfigErrors, NonIntegerOversample) {
  json j = panel_exciter_json();
  j["oversample"] = 16.5;
  EXPECT_EQ(parse_error(j), "plant.oversample: expected an integer, got number");
}

TEST(PlantConfigErrors, NonIntegerFilterOrder) {
  json j = panel_exciter_json();
  j["converters"]["da_filter"]["order"] = "4";
  EXPECT_EQ(parse_error(j), "plant.converters.da_filter.order: expected an integer, got string");
}

TEST(PlantConfigErrors, PanelModesNotAnArray) {
  json j = panel_exciter_json();
  j["panel_modes"] = {{"frequency_hz", 1000.0}, {"damping_ratio", 0.03}, {"gain", 0.2}};
  EXPECT_EQ(parse_error(j), "plant.panel_modes: expected an array, got object");
}

TEST(PlantConfigErrors, PanelModeNotAnObject) {
  json j = panel_exciter_json();
  j["panel_modes"].push_back(1000.0);
  EXPECT_EQ(parse_error(j), "plant.panel_modes[1]: expected an object, got number");
}

TEST(PlantConfigErrors, SectionNotAnObject) {
  json j = panel_exciter_json();
  j["sensor"] = json::array();
  EXPECT_EQ(parse_error(j), "plant.sensor: expected an object, got array");
}

TEST(PlantConfigErrors, NonFiniteNumber) {
  json j = panel_exciter_json();
  j["amplifier"]["offset_V"] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(parse_error(j), "plant.amplifier.offset_V: not finite");
}

TEST(PlantConfigErrors, NegativeMass) {
  json j = panel_exciter_json();
  j["mechanical"]["mass_kg"] = -1;
  EXPECT_EQ(parse_error(j), "plant.mechanical.mass_kg: must be > 0, got -1");
}

TEST(PlantConfigErrors, ZeroCoilResistance) {
  json j = panel_exciter_json();
  j["electrical"]["Re_ohm"] = 0;
  EXPECT_EQ(parse_error(j), "plant.electrical.Re_ohm: must be > 0, got 0");
}

TEST(PlantConfigErrors, NegativeDamping) {
  json j = panel_exciter_json();
  j["mechanical"]["damping_Ns_per_m"] = -0.5;
  EXPECT_EQ(parse_error(j), "plant.mechanical.damping_Ns_per_m: must be >= 0, got -0.5");
}

TEST(PlantConfigErrors, ZeroDampingIsAllowed) {
  json j = panel_exciter_json();
  j["mechanical"]["damping_Ns_per_m"] = 0;
  EXPECT_EQ(plant_from_json(j).damping_Ns_per_m, 0.0);
}

TEST(PlantConfigErrors, NegativeNoise) {
  json j = panel_exciter_json();
  j["sensor"]["noise_rms_V"] = -0.01;
  EXPECT_EQ(parse_error(j), "plant.sensor.noise_rms_V: must be >= 0, got -0.01");
}

TEST(PlantConfigErrors, NegativeScale) {
  json j = panel_exciter_json();
  j["nonlinear"]["inductance"]["scale"] = -1;
  EXPECT_EQ(parse_error(j), "plant.nonlinear.inductance.scale: must be >= 0, got -1");
}

TEST(PlantConfigErrors, PanelModeAboveSimulationNyquist) {
  // fs·oversample = 3000·16 = 48000 Hz, so the simulation's Nyquist frequency is 24000 Hz.
  json j = panel_exciter_json();
  j["panel_modes"][0]["frequency_hz"] = 24001;
  EXPECT_EQ(parse_error(j), "plant.panel_modes[0].frequency_hz: must be within [0.001, 24000], got 24001");
}

TEST(PlantConfigErrors, PanelModeDampingOutOfRange) {
  json j = panel_exciter_json();
  j["panel_modes"][0]["damping_ratio"] = 0;
  EXPECT_EQ(parse_error(j), "plant.panel_modes[0].damping_ratio: must be within [1e-06, 10], got 0");
}

TEST(PlantConfigErrors, ClippingLevelZero) {
  json j = panel_exciter_json();
  j["nonlinear"]["clipping"]["level"] = 0;
  EXPECT_EQ(parse_error(j), "plant.nonlinear.clipping.level: must be within [0.001, 10], got 0");
}

TEST(PlantConfigErrors, FilterOrderNine) {
  json j = panel_exciter_json();
  j["converters"]["da_filter"]["order"] = 9;
  EXPECT_EQ(parse_error(j), "plant.converters.da_filter.order: must be within [0, 8], got 9");
}

TEST(PlantConfigErrors, FilterCutoffAboveSimulationNyquist) {
  json j = panel_exciter_json();
  j["converters"]["ad_filter"]["cutoff_hz"] = 30000;
  EXPECT_EQ(parse_error(j), "plant.converters.ad_filter.cutoff_hz: must be within [0.001, 24000], got 30000");
}

TEST(PlantConfigErrors, SampleRateOutOfRange) {
  json j = panel_exciter_json();
  j["fs"] = 0;
  EXPECT_EQ(parse_error(j), "plant.fs: must be within [1, 384000], got 0");
}

TEST(PlantConfigErrors, WrongFormat) {
  json j = panel_exciter_json();
  j["format"] = "panelbass.model/1";
  EXPECT_EQ(parse_error(j), "plant.format: expected \"panelbass.plant/1\", got \"panelbass.model/1\"");
}

TEST(PlantConfigErrors, FormatNotAString) {
  json j = panel_exciter_json();
  j["format"] = 1;
  EXPECT_EQ(parse_error(j), "plant.format: expected a string, got number");
}

TEST(PlantConfigErrors, PanelModeMissingFrequency) {
  json j = panel_exciter_json();
  j["panel_modes"].push_back({{"damping_ratio", 0.02}, {"gain", 0.1}});
  EXPECT_EQ(parse_error(j), "plant.panel_modes[1].frequency_hz: missing");
}

TEST(PlantConfigErrors, PanelModeMissingDamping) {
  json j = panel_exciter_json();
  j["panel_modes"][0].erase("damping_ratio");
  EXPECT_EQ(parse_error(j), "plant.panel_modes[0].damping_ratio: missing");
}

TEST(PlantConfigErrors, PanelModeMissingGain) {
  json j = panel_exciter_json();
  j["panel_modes"][0].erase("gain");
  EXPECT_EQ(parse_error(j), "plant.panel_modes[0].gain: missing");
}

// ---------------------------------------------------------------------------------------------
// The integrator step against the fastest dynamics. RK4 is kept to rate·step <= 1.5, with
// step = 1/(fs·oversample), so the least oversample is ceil(rate / (1.5·fs)).

struct CoarseCase {
  const char* what;
  json plant;
  int least_oversample;  // worked out by hand in `what`
};

/// The "use at least N" of an oversample error, or -1.
int suggested_oversample(const std::string& message) {
  std::smatch match;
  if (!std::regex_search(message, match, std::regex("use at least ([0-9]+)"))) return -1;
  return std::stoi(match[1].str());
}

void check_coarse_case(const CoarseCase& c) {
  SCOPED_TRACE(c.what);
  json j = c.plant;
  j["oversample"] = 1;
  const std::string message = parse_error(j);
  EXPECT_EQ(message.rfind("plant.oversample: 1 ", 0), 0u) << message;
  const int suggested = suggested_oversample(message);
  EXPECT_EQ(suggested, c.least_oversample) << message;

  j["oversample"] = suggested;
  EXPECT_NO_THROW(plant_from_json(j)) << "the suggested oversample " << suggested << " is refused";
  j["oversample"] = suggested - 1;
  const std::string one_less = parse_error(j);
  EXPECT_EQ(one_less.rfind("plant.oversample: " + std::to_string(suggested - 1) + " ", 0), 0u) << one_less;
  EXPECT_EQ(suggested_oversample(one_less), suggested) << one_less;
}

TEST(PlantConfigOversample, CoilTimeConstantDominates) {
  // Re/Le = 4 / 0.0003 = 13333 1/s beats the 1200 Hz filters (7540 1/s) and the 1000 Hz mode (6283 1/s):
  // 13333 / 4500 = 2.96, so 3.
  check_coarse_case({"panel-exciter", panel_exciter_json(), 3});
}

TEST(PlantConfigOversample, PanelModeDominates) {
  // Le = 1 mH: Re/Le = 4000 1/s; filters off; a 1400 Hz mode gives 2π·1400 = 8796 1/s: 8796/4500 = 1.95, so 2.
  json j = panel_exciter_json();
  j["electrical"]["Le_H"] = 1e-3;
  j["converters"]["da_filter"]["order"] = 0;
  j["converters"]["ad_filter"]["order"] = 0;
  j["panel_modes"][0]["frequency_hz"] = 1400;
  check_coarse_case({"1400 Hz mode", j, 2});
}

TEST(PlantConfigOversample, ElectricalDampingDominates) {
  // m = 0.1 g: (Rm + Bl²/Re)/m = (0.4 + 2.25/4)/1e-4 = 9625 1/s beats sqrt(K/m) = 9423 1/s, the 1200 Hz
  // filters (7540 1/s) and Re/Le = 4000 1/s: 9625/4500 = 2.14, so 3.
  json j = panel_exciter_json();
  j["electrical"]["Le_H"] = 1e-3;
  j["mechanical"]["mass_kg"] = 1e-4;
  j["panel_modes"] = json::array();
  check_coarse_case({"light cone", j, 3});
}

TEST(PlantConfigOversample, PresetOversampleHasMargin) {
  // 13333 1/s at 48000 steps per second: 0.28 per step.
  EXPECT_NO_THROW(plant_from_json(panel_exciter_json()));
  json j = panel_exciter_json();
  j["oversample"] = 0;
  EXPECT_EQ(parse_error(j), "plant.oversample: must be within [1, 1024], got 0");
}

// ---------------------------------------------------------------------------------------------
// Files

/// A fresh directory for one test, removed afterwards.
class PlantConfigFile : public testing_support::ScratchDirectoryTest {};

TEST_F(PlantConfigFile, MissingFileNamesThePath) {
  const fs::path path = dir_ / "absent.json";
  EXPECT_EQ(config_error([&] { load_plant_file(path); }), path.string() + ": cannot open: No such file or directory");
}

TEST_F(PlantConfigFile, DirectoryIsAnErrorNamingThePath) {
  // A directory opens as a stream on Linux; reading it must still end in a ConfigError naming the path.
  const std::string message = config_error([&] { load_plant_file(dir_); });
  EXPECT_EQ(message.rfind(dir_.string() + ": ", 0), 0u) << message;
}

TEST_F(PlantConfigFile, InvalidJsonNamesTheFile) {
  const fs::path path = file("broken.json", "{\"fs\": 3000,");
  const std::string message = config_error([&] { load_plant_file(path); });
  EXPECT_EQ(message.rfind(path.string() + ": not valid JSON", 0), 0u) << message;
}

TEST_F(PlantConfigFile, EmptyFileNamesTheFile) {
  const fs::path path = file("empty.json", "");
  const std::string message = config_error([&] { load_plant_file(path); });
  EXPECT_EQ(message.rfind(path.string() + ": not valid JSON", 0), 0u) << message;
}

TEST_F(PlantConfigFile, BadKeyNamesTheFileAndTheKeyPath) {
  json j = panel_exciter_json();
  j["mechanical"]["masss_kg"] = 0.01;
  const fs::path path = file("typo.json", j.dump(2));
  EXPECT_EQ(config_error([&] { load_plant_file(path); }), path.string() + ": plant.mechanical.masss_kg: unknown key");
}

TEST_F(PlantConfigFile, WrittenPresetLoadsEqual) {
  for (const std::string& name : plant_preset_names()) {
    SCOPED_TRACE(name);
    const fs::path path = file(name + ".json", plant_to_json(plant_preset(name)).dump(2));
    expect_same_plant(load_plant_file(path), plant_preset(name));
  }
}

TEST_F(PlantConfigFile, HandWrittenPresetTextLoadsEqual) {
  const fs::path path = file("panel.json", kPanelExciterJson);
  expect_same_plant(load_plant_file(path), plant_preset("panel-exciter"));
}

TEST_F(PlantConfigFile, NameOrFileDispatchesOnJsonExtension) {
  // A file whose stem is a preset name is still read as a file.
  json j = panel_exciter_json();
  j["name"] = "from-file";
  j["mechanical"]["mass_kg"] = 0.02;
  const fs::path path = file("linear.json", j.dump());
  const PlantConfig from_file = plant_from_name_or_file(path.string());
  EXPECT_EQ(from_file.name, "from-file");
  EXPECT_EQ(from_file.mass_kg, 0.02);

  // A name without .json is a preset.
  expect_same_plant(plant_from_name_or_file("linear"), plant_preset("linear"));
  expect_same_plant(plant_from_name_or_file("panel-exciter"), plant_preset("panel-exciter"));

  // A missing .json file is a file error, not an unknown preset.
  const fs::path absent = dir_ / "panel-exciter.json";
  EXPECT_EQ(config_error([&] { plant_from_name_or_file(absent.string()); }),
            absent.string() + ": cannot open: No such file or directory");

  // An existing file without .json is taken as a preset name, and the error lists the presets.
  const fs::path no_extension = file("plant.txt", j.dump());
  const std::string message = config_error([&] { plant_from_name_or_file(no_extension.string()); });
  EXPECT_NE(message.find("unknown plant preset"), std::string::npos) << message;
  EXPECT_NE(message.find("panel-exciter, linear"), std::string::npos) << message;
}

}  // namespace
}  // namespace panelbass::models

#include "models/plant/plant_presets.h"

#include "models/io/config_error.h"

namespace panelbass::models {
namespace {

// The thesis's prototype (Moonen, ch. 3): fs = 3000 Hz, a badly damped main resonance whose impulse
// response needs about 200 samples to sink into the noise, a second resonance near 1000 Hz with a
// notch near 900 Hz, 1200 Hz converter filters, a 2-sample delay, and enough nonlinear distortion at
// full drive that the best linear model leaves J ≈ 5 % while the sensor noise alone is under 1 %.
// The JSON goes through the same validating loader as a user's file.
constexpr const char* kPanelExciter = R"json({
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

}  // namespace

std::vector<std::string> plant_preset_names() { return {"panel-exciter", "linear"}; }

PlantConfig plant_preset(const std::string& name) {
  const PlantConfig panel = plant_from_json(nlohmann::json::parse(kPanelExciter));
  if (name == "panel-exciter") return panel;
  if (name == "linear") {
    PlantConfig linear = linearized(panel);
    linear.name = "linear";
    return linear;
  }
  std::string names;
  for (const auto& n : plant_preset_names()) names += (names.empty() ? "" : ", ") + n;
  throw ConfigError("unknown plant preset \"" + name + "\" (presets: " + names + "; or give a .json file)");
}

PlantConfig plant_from_name_or_file(const std::string& name_or_path) {
  if (name_or_path.ends_with(".json")) return load_plant_file(name_or_path);
  return plant_preset(name_or_path);
}

}  // namespace panelbass::models

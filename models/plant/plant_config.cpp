#include "models/plant/plant_config.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <type_traits>
#include <utility>

#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/json_file.h"

namespace panelbass::models {
namespace {

constexpr const char* kFormat = "panelbass.plant/1";

// Every nonlinear term's switch, with its name in the plant file, in NonlinearTerms' order (Terms is
// NonlinearTerms, or const NonlinearTerms to read the switches only).
template <class Terms,
          class Switch = std::conditional_t<std::is_const_v<Terms>, const NonlinearSwitch, NonlinearSwitch>>
std::array<std::pair<const char*, Switch*>, 7> nonlinear_switches(Terms& n) {
  return {{{"stiffness", &n.stiffness},
           {"force_factor", &n.force_factor},
           {"inductance", &n.inductance},
           {"friction", &n.friction},
           {"clipping", &n.clipping},
           {"thermal", &n.thermal},
           {"damping", &n.damping}}};
}

// RK4 is stable up to |λh| ≈ 2.8; keeping |λh| below this leaves margin for accuracy too.
constexpr double kMaxRateTimesStep = 1.5;

void read_switch(JsonFields& f, NonlinearSwitch& s) {
  s.enabled = f.boolean("enabled", s.enabled);
  s.scale = f.number("scale", s.scale);
  require_non_negative(s.scale, f.path_of("scale"));
}

template <typename Term, typename Body>
void read_term(JsonFields& parent, const std::string& key, Term& term, Body body) {
  if (const nlohmann::json* v = parent.member(key)) {
    JsonFields f(*v, parent.path_of(key));
    read_switch(f, term);
    body(f, term);
    f.finish();
  }
}

AnalogFilter read_filter(JsonFields& parent, const std::string& key, AnalogFilter filter, double fs_sim) {
  if (const nlohmann::json* v = parent.member(key)) {
    JsonFields f(*v, parent.path_of(key));
    filter.order = static_cast<int>(f.integer("order", filter.order, 0, 8));
    filter.cutoff_hz = f.number("cutoff_hz", filter.cutoff_hz);
    require_within(filter.cutoff_hz, 1e-3, fs_sim / 2.0, f.path_of("cutoff_hz"));
    f.finish();
  }
  return filter;
}

// The fastest rate (1/s) in the linearized dynamics: what the integrator step must resolve.
double fastest_rate(const PlantConfig& c) {
  const double two_pi = 2.0 * std::numbers::pi;
  double rate = std::max(c.Re_ohm / c.Le_H, std::sqrt(c.stiffness_N_per_m / c.mass_kg));
  rate = std::max(rate, (c.damping_Ns_per_m + c.Bl_Tm * c.Bl_Tm / c.Re_ohm) / c.mass_kg);
  for (const auto& m : c.panel_modes) rate = std::max(rate, two_pi * m.frequency_hz);
  if (c.creep.fraction > 0.0) rate = std::max(rate, 1.0 / c.creep.time_constant_s);
  // The L2R2 branch: its own corner R2/L2 on top of the coil's (Re + R2)/Le (a bound on the faster eigenvalue).
  if (c.eddy.L2_H > 0.0) rate = std::max(rate, (c.Re_ohm + c.eddy.R2_ohm) / c.Le_H + c.eddy.R2_ohm / c.eddy.L2_H);
  if (c.converters.da_filter.order > 0) rate = std::max(rate, two_pi * c.converters.da_filter.cutoff_hz);
  if (c.converters.ad_filter.order > 0) rate = std::max(rate, two_pi * c.converters.ad_filter.cutoff_hz);
  return rate;
}

constexpr std::array<std::pair<SensorKind, const char*>, 4> kSensorKinds{{{SensorKind::acceleration, "acceleration"},
                                                                           {SensorKind::velocity, "velocity"},
                                                                           {SensorKind::displacement, "displacement"},
                                                                           {SensorKind::microphone, "microphone"}}};

// The sensitivity key of each kind, so that a sensitivity in another kind's unit is refused by name.
const char* sensitivity_key(SensorKind kind) {
  switch (kind) {
    case SensorKind::velocity: return "sensitivity_V_per_mps";
    case SensorKind::displacement: return "sensitivity_V_per_m";
    case SensorKind::acceleration:
    case SensorKind::microphone: break;
  }
  return "sensitivity_V_per_mps2";
}

// The sensitivity field of the sensor's kind (Sensor or const Sensor).
template <class S>
auto& sensitivity_of(S& s) {
  switch (s.kind) {
    case SensorKind::velocity: return s.sensitivity_V_per_mps;
    case SensorKind::displacement: return s.sensitivity_V_per_m;
    case SensorKind::acceleration:
    case SensorKind::microphone: break;
  }
  return s.sensitivity_V_per_mps2;
}

// The sensor's kind, its sensitivity (the key of its kind only) and, for a microphone, its delay.
void read_sensor_kind(JsonFields& f, Sensor& s) {
  const std::string kind = f.string("kind", to_string(s.kind));
  std::string known;
  bool found = false;
  for (const auto& [k, name] : kSensorKinds) {
    known += std::string(known.empty() ? "" : ", ") + name;
    if (kind == name) s.kind = k, found = true;
  }
  if (!found) throw ConfigError(f.path_of("kind") + ": unknown sensor kind \"" + kind + "\" (kinds: " + known + ")");
  for (const char* key : {"sensitivity_V_per_mps2", "sensitivity_V_per_mps", "sensitivity_V_per_m"}) {
    if (std::string(key) != sensitivity_key(s.kind) && f.member(key) != nullptr)
      throw ConfigError(f.path_of(key) + ": not the sensitivity of a " + kind + " sensor (use " + sensitivity_key(s.kind) + ")");
  }
  double& sensitivity = sensitivity_of(s);
  sensitivity = f.number(sensitivity_key(s.kind), sensitivity);
  require_positive(sensitivity, f.path_of(sensitivity_key(s.kind)));
  if (s.kind == SensorKind::microphone) {
    s.delay_samples = f.number("delay_samples", s.delay_samples);
    require_within(s.delay_samples, 0.0, 10000.0, f.path_of("delay_samples"));
  } else if (f.member("delay_samples") != nullptr) {
    throw ConfigError(f.path_of("delay_samples") + ": only a microphone sensor has a delay (the converters' is converters.delay_samples)");
  }
}

ColouredNoise read_coloured_noise(const nlohmann::json& v, const std::string& path, double fs) {
  ColouredNoise n;
  JsonFields f(v, path);
  const std::string shape = f.string("shape", "lowpass");
  if (shape == "lowpass") n.shape = NoiseShape::lowpass;
  else if (shape == "pink") n.shape = NoiseShape::pink;
  else throw ConfigError(f.path_of("shape") + ": unknown noise shape \"" + shape + "\" (shapes: lowpass, pink)");
  n.rms_V = f.number("rms_V", n.rms_V);
  require_non_negative(n.rms_V, f.path_of("rms_V"));
  if (n.shape == NoiseShape::lowpass) {
    n.corner_hz = f.number("corner_hz", n.corner_hz);
    require_within(n.corner_hz, 1e-3, fs / 2.0, f.path_of("corner_hz"));
  } else {
    n.low_hz = f.number("low_hz", n.low_hz);
    require_within(n.low_hz, 1e-3, fs / 2.0, f.path_of("low_hz"));
    n.high_hz = f.number("high_hz", std::min(n.high_hz, fs / 2.0));
    require_within(n.high_hz, n.low_hz * 1.0001, fs / 2.0, f.path_of("high_hz"));
  }
  f.finish();
  return n;
}

}  // namespace

std::string to_string(SensorKind kind) {
  for (const auto& [k, name] : kSensorKinds)
    if (k == kind) return name;
  return "acceleration";
}

double sensor_sensitivity(const Sensor& sensor) { return sensitivity_of(sensor); }

int required_oversample(const PlantConfig& c) {
  return std::max(1, static_cast<int>(std::ceil(fastest_rate(c) / (kMaxRateTimesStep * c.fs))));
}

PlantConfig plant_from_json(const nlohmann::json& json) {
  PlantConfig c;
  JsonFields top(json, "plant");
  const std::string format = top.string("format", kFormat);
  if (format != kFormat) throw ConfigError("plant.format: expected \"" + std::string(kFormat) + "\", got \"" + format + "\"");
  c.name = top.string("name", c.name);
  c.fs = top.number("fs", c.fs);
  require_within(c.fs, 1.0, 384000.0, "plant.fs");
  c.oversample = static_cast<int>(top.integer("oversample", c.oversample, 1, 1024));
  const double fs_sim = c.fs * c.oversample;

  if (const nlohmann::json* v = top.member("amplifier")) {
    JsonFields f(*v, "plant.amplifier");
    c.amplifier_gain_V = f.number("gain_V", c.amplifier_gain_V);
    require_positive(c.amplifier_gain_V, f.path_of("gain_V"));
    c.amplifier_offset_V = f.number("offset_V", c.amplifier_offset_V);
    f.finish();
  }
  if (const nlohmann::json* v = top.member("electrical")) {
    JsonFields f(*v, "plant.electrical");
    c.Re_ohm = f.number("Re_ohm", c.Re_ohm);
    require_positive(c.Re_ohm, f.path_of("Re_ohm"));
    c.Le_H = f.number("Le_H", c.Le_H);
    require_positive(c.Le_H, f.path_of("Le_H"));
    c.eddy.L2_H = f.number("L2_H", c.eddy.L2_H);
    require_within(c.eddy.L2_H, 0.0, 1.0, f.path_of("L2_H"));
    c.eddy.R2_ohm = f.number("R2_ohm", c.eddy.R2_ohm);
    require_positive(c.eddy.R2_ohm, f.path_of("R2_ohm"));
    f.finish();
  }
  if (const nlohmann::json* v = top.member("mechanical")) {
    JsonFields f(*v, "plant.mechanical");
    c.mass_kg = f.number("mass_kg", c.mass_kg);
    require_positive(c.mass_kg, f.path_of("mass_kg"));
    c.stiffness_N_per_m = f.number("stiffness_N_per_m", c.stiffness_N_per_m);
    require_positive(c.stiffness_N_per_m, f.path_of("stiffness_N_per_m"));
    c.damping_Ns_per_m = f.number("damping_Ns_per_m", c.damping_Ns_per_m);
    require_non_negative(c.damping_Ns_per_m, f.path_of("damping_Ns_per_m"));
    c.Bl_Tm = f.number("Bl_Tm", c.Bl_Tm);
    require_positive(c.Bl_Tm, f.path_of("Bl_Tm"));
    if (const nlohmann::json* w = f.member("creep")) {
      JsonFields g(*w, f.path_of("creep"));
      c.creep.fraction = g.number("fraction", c.creep.fraction);
      require_within(c.creep.fraction, 0.0, 0.95, g.path_of("fraction"));
      c.creep.time_constant_s = g.number("time_constant_s", c.creep.time_constant_s);
      require_within(c.creep.time_constant_s, 1e-4, 1e4, g.path_of("time_constant_s"));
      g.finish();
    }
    f.finish();
  }
  if (const nlohmann::json* v = top.member("nonlinear")) {
    JsonFields f(*v, "plant.nonlinear");
    NonlinearTerms& n = c.nonlinear;
    read_term(f, "stiffness", n.stiffness, [](JsonFields& g, StiffnessTerm& t) {
      t.k1_per_mm = g.number("k1_per_mm", t.k1_per_mm);
      t.k2_per_mm2 = g.number("k2_per_mm2", t.k2_per_mm2);
    });
    read_term(f, "force_factor", n.force_factor, [](JsonFields& g, ForceFactorTerm& t) {
      t.b1_per_mm = g.number("b1_per_mm", t.b1_per_mm);
      t.b2_per_mm2 = g.number("b2_per_mm2", t.b2_per_mm2);
    });
    read_term(f, "inductance", n.inductance, [](JsonFields& g, InductanceTerm& t) {
      t.l1_per_mm = g.number("l1_per_mm", t.l1_per_mm);
      t.l2_per_mm2 = g.number("l2_per_mm2", t.l2_per_mm2);
      t.li2_per_A2 = g.number("li2_per_A2", t.li2_per_A2);
    });
    read_term(f, "friction", n.friction, [](JsonFields& g, FrictionTerm& t) {
      t.coulomb_N = g.number("coulomb_N", t.coulomb_N);
      require_non_negative(t.coulomb_N, g.path_of("coulomb_N"));
      t.velocity_scale_m_per_s = g.number("velocity_scale_m_per_s", t.velocity_scale_m_per_s);
      require_positive(t.velocity_scale_m_per_s, g.path_of("velocity_scale_m_per_s"));
    });
    read_term(f, "clipping", n.clipping, [](JsonFields& g, ClippingTerm& t) {
      t.level = g.number("level", t.level);
      require_within(t.level, 1e-3, 10.0, g.path_of("level"));
      t.knee = g.number("knee", t.knee);
      require_within(t.knee, 1e-6, 10.0, g.path_of("knee"));
    });
    read_term(f, "damping", n.damping, [](JsonFields& g, DampingTerm& t) {
      t.r2_per_m2ps2 = g.number("r2_per_m2ps2", t.r2_per_m2ps2);
      require_non_negative(t.r2_per_m2ps2, g.path_of("r2_per_m2ps2"));
    });
    read_term(f, "thermal", n.thermal, [](JsonFields& g, ThermalTerm& t) {
      t.alpha_per_K = g.number("alpha_per_K", t.alpha_per_K);
      require_non_negative(t.alpha_per_K, g.path_of("alpha_per_K"));
      t.resistance_K_per_W = g.number("resistance_K_per_W", t.resistance_K_per_W);
      require_non_negative(t.resistance_K_per_W, g.path_of("resistance_K_per_W"));
      t.time_constant_s = g.number("time_constant_s", t.time_constant_s);
      require_positive(t.time_constant_s, g.path_of("time_constant_s"));
    });
    f.finish();
  }
  if (const nlohmann::json* v = top.member("panel_modes")) {
    if (!v->is_array()) throw ConfigError("plant.panel_modes: expected an array, got " + std::string(v->type_name()));
    for (std::size_t k = 0; k < v->size(); ++k) {
      JsonFields f((*v)[k], "plant.panel_modes[" + std::to_string(k) + "]");
      PanelMode m;
      m.frequency_hz = f.number("frequency_hz");
      require_within(m.frequency_hz, 1e-3, fs_sim / 2.0, f.path_of("frequency_hz"));
      m.damping_ratio = f.number("damping_ratio");
      require_within(m.damping_ratio, 1e-6, 10.0, f.path_of("damping_ratio"));
      m.gain = f.number("gain");
      f.finish();
      c.panel_modes.push_back(m);
    }
  }
  if (const nlohmann::json* v = top.member("converters")) {
    JsonFields f(*v, "plant.converters");
    c.converters.da_filter = read_filter(f, "da_filter", c.converters.da_filter, fs_sim);
    c.converters.ad_filter = read_filter(f, "ad_filter", c.converters.ad_filter, fs_sim);
    c.converters.delay_samples = static_cast<int>(f.integer("delay_samples", c.converters.delay_samples, 0, 100000));
    f.finish();
  }
  if (const nlohmann::json* v = top.member("sensor")) {
    JsonFields f(*v, "plant.sensor");
    read_sensor_kind(f, c.sensor);
    c.sensor.offset_V = f.number("offset_V", c.sensor.offset_V);
    c.sensor.noise_rms_V = f.number("noise_rms_V", c.sensor.noise_rms_V);
    require_non_negative(c.sensor.noise_rms_V, f.path_of("noise_rms_V"));
    c.sensor.preamp_clip_V = f.number("preamp_clip_V", c.sensor.preamp_clip_V);
    require_non_negative(c.sensor.preamp_clip_V, f.path_of("preamp_clip_V"));
    if (const nlohmann::json* w = f.member("coloured_noise")) c.sensor.coloured_noise = read_coloured_noise(*w, f.path_of("coloured_noise"), c.fs);
    f.finish();
  }
  top.finish();

  if (c.oversample < required_oversample(c)) {
    const int needed = required_oversample(c);
    throw ConfigError("plant.oversample: " + std::to_string(c.oversample) +
                      " integrator steps per sample are too coarse for the fastest dynamics (" +
                      std::to_string(fastest_rate(c)) + " 1/s); use at least " + std::to_string(needed));
  }
  return c;
}

nlohmann::json plant_to_json(const PlantConfig& c) {
  using nlohmann::json;
  auto sw = [](const NonlinearSwitch& s) { return json{{"enabled", s.enabled}, {"scale", s.scale}}; };
  const NonlinearTerms& n = c.nonlinear;
  json stiffness = sw(n.stiffness);
  stiffness["k1_per_mm"] = n.stiffness.k1_per_mm;
  stiffness["k2_per_mm2"] = n.stiffness.k2_per_mm2;
  json force = sw(n.force_factor);
  force["b1_per_mm"] = n.force_factor.b1_per_mm;
  force["b2_per_mm2"] = n.force_factor.b2_per_mm2;
  json inductance = sw(n.inductance);
  inductance["l1_per_mm"] = n.inductance.l1_per_mm;
  inductance["l2_per_mm2"] = n.inductance.l2_per_mm2;
  inductance["li2_per_A2"] = n.inductance.li2_per_A2;
  json friction = sw(n.friction);
  friction["coulomb_N"] = n.friction.coulomb_N;
  friction["velocity_scale_m_per_s"] = n.friction.velocity_scale_m_per_s;
  json clipping = sw(n.clipping);
  clipping["level"] = n.clipping.level;
  clipping["knee"] = n.clipping.knee;
  json thermal = sw(n.thermal);
  thermal["alpha_per_K"] = n.thermal.alpha_per_K;
  thermal["resistance_K_per_W"] = n.thermal.resistance_K_per_W;
  thermal["time_constant_s"] = n.thermal.time_constant_s;
  json modes = json::array();
  for (const auto& m : c.panel_modes) {
    modes.push_back({{"frequency_hz", m.frequency_hz}, {"damping_ratio", m.damping_ratio}, {"gain", m.gain}});
  }
  auto filter = [](const AnalogFilter& f) { return json{{"order", f.order}, {"cutoff_hz", f.cutoff_hz}}; };
  json out{
      {"format", kFormat},
      {"name", c.name},
      {"fs", c.fs},
      {"oversample", c.oversample},
      {"amplifier", {{"gain_V", c.amplifier_gain_V}, {"offset_V", c.amplifier_offset_V}}},
      {"electrical", {{"Re_ohm", c.Re_ohm}, {"Le_H", c.Le_H}}},
      {"mechanical",
       {{"mass_kg", c.mass_kg},
        {"stiffness_N_per_m", c.stiffness_N_per_m},
        {"damping_Ns_per_m", c.damping_Ns_per_m},
        {"Bl_Tm", c.Bl_Tm}}},
      {"nonlinear",
       {{"stiffness", stiffness},
        {"force_factor", force},
        {"inductance", inductance},
        {"friction", friction},
        {"clipping", clipping},
        {"thermal", thermal}}},
      {"panel_modes", modes},
      {"converters",
       {{"da_filter", filter(c.converters.da_filter)},
        {"ad_filter", filter(c.converters.ad_filter)},
        {"delay_samples", c.converters.delay_samples}}},
      {"sensor",
       {{"sensitivity_V_per_mps2", c.sensor.sensitivity_V_per_mps2},
        {"offset_V", c.sensor.offset_V},
        {"noise_rms_V", c.sensor.noise_rms_V}}},
  };
  // Written only when used, so that a plant without them (every preset) writes the JSON it always has.
  const DampingTerm plain_damping;
  if (n.damping.enabled || n.damping.scale != plain_damping.scale || n.damping.r2_per_m2ps2 != plain_damping.r2_per_m2ps2) {
    json damping = sw(n.damping);
    damping["r2_per_m2ps2"] = n.damping.r2_per_m2ps2;
    out["nonlinear"]["damping"] = damping;
  }
  if (c.sensor.preamp_clip_V != 0.0) out["sensor"]["preamp_clip_V"] = c.sensor.preamp_clip_V;
  if (c.sensor.kind != SensorKind::acceleration) {
    nlohmann::json& sensor = out["sensor"];
    sensor.erase("sensitivity_V_per_mps2");
    sensor["kind"] = to_string(c.sensor.kind);
    sensor[sensitivity_key(c.sensor.kind)] = sensor_sensitivity(c.sensor);
    if (c.sensor.kind == SensorKind::microphone) sensor["delay_samples"] = c.sensor.delay_samples;
  }
  if (const ColouredNoise& n = c.sensor.coloured_noise; n.rms_V != 0.0) {
    nlohmann::json noise{{"shape", n.shape == NoiseShape::pink ? "pink" : "lowpass"}, {"rms_V", n.rms_V}};
    if (n.shape == NoiseShape::lowpass) noise["corner_hz"] = n.corner_hz;
    else noise["low_hz"] = n.low_hz, noise["high_hz"] = n.high_hz;
    out["sensor"]["coloured_noise"] = noise;
  }
  if (c.eddy.L2_H != 0.0) out["electrical"]["L2_H"] = c.eddy.L2_H, out["electrical"]["R2_ohm"] = c.eddy.R2_ohm;
  if (c.creep.fraction != 0.0)
    out["mechanical"]["creep"] = {{"fraction", c.creep.fraction}, {"time_constant_s", c.creep.time_constant_s}};
  return out;
}

PlantConfig load_plant_file(const std::filesystem::path& path) {
  return read_json_file_as(path, plant_from_json);
}

PlantConfig without_sensor_noise(PlantConfig c) {
  c.sensor.noise_rms_V = 0.0;
  c.sensor.coloured_noise.rms_V = 0.0;
  return c;
}

PlantConfig linearized(PlantConfig c) {
  for (const auto& [name, term] : nonlinear_switches(c.nonlinear)) term->enabled = false;
  return c;
}

std::vector<std::string> enabled_nonlinear_terms(const PlantConfig& config) {
  std::vector<std::string> names;
  for (const auto& [name, term] : nonlinear_switches(config.nonlinear)) {
    if (term->enabled) names.push_back(name);
  }
  return names;
}

PlantConfig with_only_term(PlantConfig c, const std::string& name) {
  std::string known;
  bool found = false;
  for (const auto& [term_name, term] : nonlinear_switches(c.nonlinear)) {
    known += std::string(known.empty() ? "" : ", ") + term_name;
    if (term_name == name) found = true;
    else term->enabled = false;
  }
  if (!found) throw ConfigError("unknown nonlinear term \"" + name + "\" (terms: " + known + ")");
  return c;
}

}  // namespace panelbass::models

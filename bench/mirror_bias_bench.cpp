// Oracle experiments on the current-only mirror fit's bias (issue #56): fits the gray-box model [M1]–[M3] of
// mirror_filter.h three ways on one record of a plant — with the displacement column (fit_mirror_model), from the
// current alone and from the current with the accelerometer (fit_mirror_model_from_current) — puts the latent fits in
// the true x's units (their free-run x regressed on the record's), prints the coefficients side by side with the
// plant's own, then swaps single parameter groups from a donor fit into the current-only model and prints the
// mirror filter's THD cut (evaluate's level sweep at equal output level) for each.
// With `card` as its fourth argument it fits from what a sound card records instead: the plant simulated at 16·fs,
// the drive held over each sample, the loopback (the drive through the DA filter) and the coil current both through
// the card's AD filter (4th-order Butterworth at 1200 Hz at 16·fs) and taken every 16th sample at an offset of 5,
// the current-only fit's lag search finding their timing; the filters are evaluated on the plant at fs.
// With `adapt` as its fourth argument: the current-only fit's filter, fixed and adapting from the coil current
// (mirror_current_adapter.h), each closed over ±20 % variants of the plant (`plant vary --by 0.2 --seed N`, N = 1, 2,
// 3, 6) with the measured current fed back; the THD cut at equal output (the plant alone's drive searched until its
// sensor fundamental matches) after 4 s of the probe sine, measured over the next 2 s.
//   mirror_bias_bench [PLANT] [SAMPLES] [ONLY] [card|adapt]   (PLANT a preset or a .json; its sensor noise is switched off;
//   ONLY: evaluate only the rows whose name contains it)
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "dsp/butterworth.h"
#include "dsp/excitation.h"
#include "dsp/harmonics.h"
#include "engine/mirror_filter_stage.h"
#include "models/plant/plant_variants.h"
#include "engine/chain_file.h"
#include "evaluation/level_sweep.h"
#include "models/control/mirror_current_fit.h"
#include "models/control/mirror_filter.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"

using namespace panelbass;

namespace {

/// The model's free-run displacement on the drive (the model's delay applied).
Eigen::VectorXd model_displacement(const models::MirrorModel& m, const Eigen::VectorXd& drive, int lag) {
  models::MirrorState s;
  Eigen::VectorXd x(drive.size());
  for (Eigen::Index k = 0; k < drive.size(); ++k) {
    const Eigen::Index at = k - lag;
    models::step_mirror_model(m, s, at >= 0 ? drive[at] : 0.0);
    x[k] = s.x;
  }
  return x;
}

/// α with x_true ≈ α·x_model (best over a shift of −3..3 samples), and the relative residual.
double x_scale(const models::MirrorModel& m, const Eigen::VectorXd& drive, const Eigen::VectorXd& x_mm, int lag) {
  const Eigen::VectorXd xm = model_displacement(m, drive, lag);
  double best = 1e300, alpha = 1.0;
  const Eigen::Index n = drive.size(), first = 100;
  for (int s = -3; s <= 3; ++s) {
    const Eigen::VectorXd a = xm.segment(first + s, n - 2 * first), b = x_mm.segment(first, n - 2 * first);
    const double al = a.dot(b) / a.squaredNorm();
    const double r = (al * a - b).squaredNorm() / b.squaredNorm();
    if (r < best) {
      best = r;
      alpha = al;
    }
  }
  std::fprintf(stderr, "  x scale %.6g, residual %.4f %%\n", alpha, 100.0 * best);
  return alpha;
}

struct Cuts {
  std::vector<double> c;  // 40/80/160 × 0.1/0.2/0.3 (NaN: not reachable)
};

Cuts evaluate(const models::MirrorModel& m, const models::PlantConfig& plant) {
  nlohmann::json chain = {{"format", "panelbass.chain/1"},
                          {"fs", m.fs},
                          {"band_pass", {{"low_hz", 0.0}, {"high_hz", 1200.0}, {"order", 2}, {"bypass", false}}},
                          {"feedforward", {{"model", models::mirror_model_to_json(m)}, {"bypass", false}}}};
  const engine::ChainConfig config = engine::chain_config_from_json(chain, ".");
  evaluation::LevelSweepOptions o;
  o.frequencies_hz = {40.0, 80.0, 160.0};
  o.program_amplitudes = {0.1, 0.2, 0.3};
  const evaluation::LevelSweep sweep = evaluation::sweep_levels(config, plant, o);
  Cuts out;
  for (const auto& curve : sweep.curves) {
    for (const auto& p : curve.points) out.c.push_back(p.reachable ? p.cut_db : NAN);
  }
  return out;
}

void print_row(const std::string& name, const Cuts& c) {
  std::printf("| %-44s |", name.c_str());
  for (std::size_t f = 0; f < 3; ++f) {
    std::printf(" ");
    for (std::size_t l = 0; l < 3; ++l) {
      const double v = c.c[3 * f + l];
      if (std::isnan(v)) std::printf("n.r.");
      else std::printf("%.1f", v);
      std::printf(l < 2 ? " / " : " |");
    }
  }
  std::printf("\n");
  std::fflush(stdout);
}

void print_model(const std::string& name, const models::MirrorModel& m) {
  const auto& c = m.mechanical;
  const auto& e = m.electrical;
  std::printf("%-8s c0 %.5g b2 %.4f c3/c0 %.4g c5 %.4g K0/m %.6g k1 %.4f k2 %.4f fr/c0 %.4g v0 %.3g | eR %.5g e5/eR %.5g "
              "e8/e5 %.4g e9 %.3g | taps %.4f %.4f %.4f delay %d\n",
              name.c_str(), c[0], c[2] / c[0], c[3] / c[0], c[5], -c[6], c[7] / c[6], c[8] / c[6], c[9] / c[0],
              m.friction_velocity, e[4], e[5] / e[4], e[8] / e[5], e[9], m.drive_taps[1], m.drive_taps[2],
              m.drive_taps[3], m.delay);
}

/// What a card records from `plant` driven by `drive`: the loopback and the coil current (see the top).
std::pair<Eigen::VectorXd, Eigen::VectorXd> card_record(models::PlantConfig plant, const Eigen::VectorXd& drive) {
  constexpr int kUp = 16, kOffset = 5;
  const double fs = plant.fs * kUp;
  plant.fs = fs;
  plant.oversample = 1;
  plant.converters.delay_samples = 0;
  Eigen::VectorXd held(drive.size() * kUp);
  for (Eigen::Index k = 0; k < held.size(); ++k) held[k] = drive[k / kUp];
  const models::PlantRecord fast = models::simulate(plant, held, 1);
  dsp::SosFilter da(dsp::butterworth_lowpass(4, 1200.0, fs)), ad_u(dsp::butterworth_lowpass(4, 1200.0, fs)),
      ad_i(dsp::butterworth_lowpass(4, 1200.0, fs));
  Eigen::VectorXd loopback(drive.size()), current(drive.size());
  for (Eigen::Index k = 0; k < held.size(); ++k) {
    const double u = ad_u.process(da.process(held[k])), i = ad_i.process(fast.i[k]);
    if (k % kUp == kOffset) {
      loopback[k / kUp] = u;
      current[k / kUp] = i;
    }
  }
  return {loopback, current};
}

/// THD % and fundamental of the plant's clean sensor output over the last 2 s of 6 s of a sine at `f`, through
/// `stage` (null: the sine drives the plant alone) with the plant's current fed back to it.
Eigen::VectorXd warmup;  // the broadband program an adapting stage hears first (empty: none)

std::pair<double, double> closed_thd(const models::PlantConfig& plant, engine::MirrorFilterStage* stage, double f,
                                     double amplitude) {
  models::VirtualTransducer t(plant, 1);
  const int n = static_cast<int>(6.0 * plant.fs), measured = static_cast<int>(2.0 * plant.fs);
  if (stage != nullptr) stage->reset();
  if (stage != nullptr && stage->current_adapter() != nullptr && warmup.size() > 0) {
    // the adaptation first hears a broadband program (as music would give it), then the probe
    for (Eigen::Index k = 0; k < warmup.size(); ++k) stage->observe(t.step(std::clamp(stage->process(warmup[k]), -1.0, 1.0)).i);
  }
  Eigen::VectorXd y(measured);
  for (int k = 0; k < n; ++k) {
    const double program = amplitude * std::sin(2.0 * M_PI * f * k / plant.fs);
    const double drive = stage != nullptr ? std::clamp(stage->process(program), -1.0, 1.0) : program;
    const models::PlantSample s = t.step(drive);
    if (stage != nullptr) stage->observe(s.i);
    if (k >= n - measured) y[k - (n - measured)] = s.y_clean;
  }
  const dsp::HarmonicLevels h = dsp::harmonic_levels(y, plant.fs, f);
  return {h.thd_percent(), h.amplitude[0]};
}

/// The cut at equal output: the plant alone's sine amplitude scaled until its fundamental is the chain's.
double cut_at_equal_output(const models::PlantConfig& plant, engine::MirrorFilterStage& stage, double f, double program) {
  const auto [chain_thd, chain_fundamental] = closed_thd(plant, &stage, f, program);
  double a = program, thd = 0.0;
  for (int it = 0; it < 6; ++it) {
    const auto [t, fundamental] = closed_thd(plant, nullptr, f, a);
    thd = t;
    a *= chain_fundamental / fundamental;
  }
  return 20.0 * std::log10(thd / chain_thd);
}

void adapt_rows(const models::PlantConfig& design_plant, const models::MirrorCurrentFit& fit, const Eigen::VectorXd& current) {
  models::MirrorModel adaptive = fit.model;
  adaptive.observer.enabled = true;
  adaptive.observer.measurement = models::MirrorMeasurement::current;
  adaptive.observer.current_lag = fit.current_lag;
  const double rms = std::sqrt(current.squaredNorm() / static_cast<double>(current.size()));
  adaptive.observer.current_noise = std::max(std::sqrt(fit.current_j_val_pct / 100.0), 1e-3) * rms;
  if (std::getenv("RATE") != nullptr) adaptive.observer.scale_rate = std::atof(std::getenv("RATE"));
  if (std::getenv("WARMUP") != nullptr) {
    dsp::MultisineSpec spec;
    spec.period = 12000;
    spec.f_min = 10.0;
    spec.f_max = 300.0;
    spec.amplitude = std::atof(std::getenv("WARMUP"));
    spec.seed = 7;
    warmup = dsp::multisine(spec).signal;
  }
  std::printf("| plant | filter | 40 Hz | 80 Hz | 160 Hz | scales R / Bl / K / N at 80 Hz 0.2 |\n|---|---|---|---|---|---|\n");
  for (std::uint64_t seed : {1u, 2u, 3u, 6u}) {
    models::PlantConfig plant = models::varied_plant(design_plant, 0.2, seed);
    plant.sensor.noise_rms_V = 0.0;
    for (int which = 0; which < 2; ++which) {
      engine::MirrorFilterStage stage(which == 0 ? fit.model : adaptive);
      std::printf("| variant seed %d | %s |", static_cast<int>(seed), which == 0 ? "fixed" : "adaptive (current)");
      std::string scales;
      for (double f : {40.0, 80.0, 160.0}) {
        for (double program : {0.1, 0.2, 0.3}) {
          std::printf(" %.1f%s", cut_at_equal_output(plant, stage, f, program), program < 0.25 ? " /" : " |");
          if (f == 80.0 && program == 0.2 && stage.current_adapter() != nullptr) {
            (void)closed_thd(plant, &stage, f, program);
            const models::MirrorScales s = stage.current_adapter()->scales();
            char text[128];
            std::snprintf(text, sizeof text, " %.3f / %.3f / %.3f / %.3f", s.resistance, s.force_factor, s.stiffness, s.nonlinear);
            scales = text;
          }
        }
      }
      std::printf("%s |\n", scales.c_str());
      std::fflush(stdout);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  const std::string plant_name = argc > 1 ? argv[1] : "panel-exciter";
  const std::size_t samples = argc > 2 ? std::stoul(argv[2]) : 30000;
  const std::string only = argc > 3 ? argv[3] : "";
  const bool card = argc > 4 && std::string(argv[4]) == "card";
  const bool adapt = argc > 4 && std::string(argv[4]) == "adapt";
  models::PlantConfig plant = models::plant_from_name_or_file(plant_name);
  dsp::MultisineSpec spec;
  spec.period = samples;
  spec.fs = plant.fs;
  spec.f_min = 10.0;
  spec.f_max = 300.0;
  spec.amplitude = 0.5;
  spec.seed = 1;
  const Eigen::VectorXd drive = dsp::multisine(spec).signal;
  const models::PlantRecord rec = models::simulate(plant, drive, 1);
  plant.sensor.noise_rms_V = 0.0;
  const Eigen::VectorXd x_mm = rec.x * 1000.0;

  const models::MirrorFit xfit = models::fit_mirror_model(drive, rec.i, rec.x, plant.fs);
  if (card) {
    const auto [loopback, current] = card_record(plant, drive);
    const models::MirrorCurrentFit fit = models::fit_mirror_model_from_current(loopback, current, plant.fs);
    std::fprintf(stderr, "card record: current J_val %.4f %% (linear %.4f %%), lag %d, b1 %s\n", fit.current_j_val_pct,
                 fit.linear_j_val_pct, fit.current_lag, fit.force_factor_asymmetry ? "kept" : "out");
    print_model("card", models::rescale_displacement(fit.model, x_scale(fit.model, loopback, x_mm, fit.model.delay)));
    print_row("current only, card record", evaluate(fit.model, plant));
    return 0;
  }
  models::MirrorCurrentFit co = models::fit_mirror_model_from_current(drive, rec.i, plant.fs);
  if (adapt) {
    adapt_rows(plant, co, rec.i);
    return 0;
  }
  models::MirrorCurrentFitOptions ao;
  ao.sensor_kind = models::MirrorSensorKind::acceleration;
  models::MirrorCurrentFit ca = models::fit_mirror_model_from_current(drive, rec.i, plant.fs, ao, rec.y);
  std::fprintf(stderr, "current only: J_val %.4f %% lag %d; with acc: J_val %.4f %% / %.3f %%\n", co.current_j_val_pct,
               co.current_lag, ca.current_j_val_pct, ca.sensor_j_val_pct);
  const models::MirrorModel CO = models::rescale_displacement(co.model, x_scale(co.model, drive, x_mm, co.model.delay));
  const models::MirrorModel CA = models::rescale_displacement(ca.model, x_scale(ca.model, drive, x_mm, ca.model.delay));
  const models::MirrorModel& XF = xfit.model;
  print_model("x-fit", XF);
  print_model("cur", CO);
  print_model("cur+acc", CA);

  std::printf("| model | 40 Hz | 80 Hz | 160 Hz |\n|---|---|---|---|\n");
  const auto run = [&](const std::string& name, const models::MirrorModel& m) {
    if (!only.empty() && name.find(only) == std::string::npos) return;
    print_row(name, evaluate(m, plant));
  };
  run("x-fit", XF);
  run("current only", CO);
  run("current + acc", CA);
  // parameter groups: (mechanical indices, electrical indices, taps/delay, friction velocity)
  struct Group {
    std::string name;
    std::vector<int> mech, elec;
    bool taps = false, v0 = false;
  };
  const std::vector<Group> groups = {
      {"K(x) c7 c8", {7, 8}, {}},
      {"Bl(x) c1 c2 e6 e7", {1, 2}, {6, 7}},
      {"reluctance c3 c4", {3, 4}, {}},
      {"friction c9 v0", {9}, {}, false, true},
      {"e8 e9", {}, {8, 9}},
      {"linear mech c0 c5 c6", {0, 5, 6}, {}},
      {"resonance c6", {6}, {}},
      {"damping c5", {5}, {}},
      {"linear elec eR e5", {}, {4, 5}},
      {"A(z) and delay", {}, {}, true},
      {"all linear", {0, 5, 6}, {4, 5}, true},
      {"all nonlinear", {1, 2, 3, 4, 7, 8, 9}, {6, 7, 8, 9}, false, true},
  };
  for (const auto& [donor_name, donor] : {std::pair{"x-fit", &XF}, std::pair{"cur+acc", &CA}}) {
    for (const Group& g : groups) {
      models::MirrorModel m = CO;
      // the shape coefficients swapped relative to their linear ones (c0, c6, e5), so that a swap of a shape does not
      // carry the donor's linear scale with it
      for (int j : g.mech) {
        const auto u = static_cast<std::size_t>(j);
        const std::size_t base = (j == 7 || j == 8) ? 6 : (j == 5 || j == 6 || j == 0) ? 99 : 0;
        m.mechanical[u] = base == 99 ? donor->mechanical[u]
                                     : donor->mechanical[u] / donor->mechanical[base] * CO.mechanical[base];
      }
      for (int j : g.elec) {
        const auto u = static_cast<std::size_t>(j);
        m.electrical[u] = (j == 4 || j == 5) ? donor->electrical[u]
                                             : donor->electrical[u] / donor->electrical[5] * CO.electrical[5];
      }
      if (g.taps) {
        m.drive_taps = donor->drive_taps;
        m.delay = donor->delay;
      }
      if (g.v0) m.friction_velocity = donor->friction_velocity;
      run(std::string("cur ← ") + donor_name + " " + g.name, m);
    }
  }
  return 0;
}

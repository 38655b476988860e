// The Linear issue's figures on the virtual transducer: the `linear` preset recovered by OE, Zhu and
// Backx (worst magnitude error over 20–1200 Hz, validation J against the noise floor), and the
// `panel-exciter` order scan with Zhu, Backx and ARX side by side (ARX's simulation J beside its
// prediction J). Usage: build/bin/linear_preset_bench [SEED]

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "dsp/excitation.h"
#include "dsp/spectrum.h"
#include "models/linear/linear_identification.h"
#include "models/validation/performance.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"

using namespace panelbass;

namespace {

struct Data {
  Eigen::VectorXd u_est, y_est, u_val, y_val, y_val_clean;
};

Data make(const std::string& preset, std::uint64_t seed, Eigen::Index estimation) {
  models::PlantConfig plant = models::plant_preset(preset);
  models::PlantConfig quiet = plant;
  quiet.sensor.noise_rms_V = 0.0;
  const Eigen::VectorXd u = dsp::uniform_noise(static_cast<std::size_t>(estimation) + 2000, 1.0, seed);
  const Eigen::VectorXd y = models::simulate(plant, u, seed + 100).y;
  const Eigen::VectorXd clean = models::simulate(quiet, u, seed + 100).y;
  return {u.head(estimation), y.head(estimation), u.tail(2000), y.tail(2000), clean.tail(2000)};
}

models::LinearIdentificationSpec spec(models::LinearMethod m, int order, int delay = -1) {
  models::LinearIdentificationSpec s;
  s.method = m;
  s.order = order;
  s.delay = delay;
  s.fs = 3000.0;
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  const std::uint64_t seed = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 1;

  models::PlantConfig quiet = models::plant_preset("linear");
  quiet.sensor.noise_rms_V = 0.0;
  const Eigen::VectorXd u_long = dsp::uniform_noise(1 << 18, 1.0, 77);
  const dsp::FrequencyResponse reference =
      dsp::h1_frf(u_long, models::simulate(quiet, u_long, 1).y, 3000.0, {4096, 0.5, dsp::Window::hann});

  std::printf("## `linear` preset, order 13, nk = 1 (seed %llu)\n\n", static_cast<unsigned long long>(seed));
  std::printf("| estimation samples | method | worst |ΔdB| 20–1200 Hz | at Hz | J_val %% | noise floor %% |\n|---:|---|---:|---:|---:|---:|\n");
  for (Eigen::Index n : {10000, 200000}) {
    const Data d = make("linear", seed, n);
    const double floor = models::j_percent(d.y_val_clean, d.y_val, 50);
    for (models::LinearMethod m : {models::LinearMethod::oe, models::LinearMethod::zhu, models::LinearMethod::backx}) {
      const auto id = models::identify_linear(d.u_est, d.y_est, d.u_val, d.y_val, spec(m, 13, 1));
      const double gain = id.model.scaling.y_scale / id.model.scaling.u_scale;
      double worst = 0.0, at = 0.0;
      for (Eigen::Index k = 0; k < reference.frequency.size(); ++k) {
        const double f = reference.frequency[k];
        if (f < 20.0 || f > 1200.0) continue;
        const double e = std::abs(20 * std::log10(std::abs(id.model.tf.response(f, 3000.0)) * gain / std::abs(reference.h[k])));
        if (e > worst) worst = e, at = f;
      }
      std::printf("| %ld | %s | %.2f | %.0f | %.3f | %.3f |\n", static_cast<long>(n), models::to_string(m).c_str(), worst, at,
                  id.j_val_pct, floor);
    }
  }

  const Data d = make("panel-exciter", seed, 10000);
  models::LinearIdentificationSpec scan = spec(models::LinearMethod::zhu, 0);
  scan.scan_from = 1;
  scan.scan_to = 12;
  const auto scanned = models::identify_linear(d.u_est, d.y_est, d.u_val, d.y_val, scan);
  std::printf("\n## `panel-exciter`, 10 000 + 2 000 samples: Zhu order scan (fig. 4.8)\n\n| order | J_est %% | J_val %% |\n|---:|---:|---:|\n");
  for (const auto& e : scanned.scan) std::printf("| %d | %.2f | %.2f |\n", e.order, e.j_est_pct, e.j_val_pct);
  std::printf("\nchosen order %d: %s\n", scanned.model.tf.na(), scanned.order_rule.c_str());

  std::printf("\n## `panel-exciter`, order 8, side by side\n\n| method | J_est %% (sim) | J_est %% (pred) | J_val %% (sim) |\n|---|---:|---:|---:|\n");
  for (models::LinearMethod m : {models::LinearMethod::arx, models::LinearMethod::oe, models::LinearMethod::zhu, models::LinearMethod::backx}) {
    const auto id = models::identify_linear(d.u_est, d.y_est, d.u_val, d.y_val, spec(m, 8));
    std::printf("| %s | %.2f | %.2f | %.2f |\n", models::to_string(m).c_str(), id.j_est_pct, id.j_pred_est_pct, id.j_val_pct);
  }
  return 0;
}

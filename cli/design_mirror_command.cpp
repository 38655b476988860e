// `panelbass design mirror`: Klippel's mirror filter fitted to a record of drive, coil current and
// displacement (models/control/mirror_filter.h) — the gray-box physics of the exciter from identification
// data alone, written as a model file the chain runs as its feedforward stage.
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "dsp/data_file.h"
#include "models/control/mirror_filter.h"
#include "models/control/mirror_observer.h"
#include "models/io/json_file.h"

namespace panelbass::cli {
namespace {

struct DesignMirrorOptions {
  std::string data, out;
  double fs = 0.0;
  std::string input_col = "u", current_col = "i", displacement_col = "x", sensor_col = "y";
  int max_delay = 4;
  bool adapt = false;
  double stiffness_rate = models::MirrorObserverSettings{}.stiffness_rate;
  double stiffness_spread = models::MirrorObserverSettings{}.stiffness_spread;
};

void run_design_mirror(const DesignMirrorOptions& o) {
  std::vector<std::string> columns{o.input_col, o.current_col, o.displacement_col};
  if (o.adapt) columns.push_back(o.sensor_col);
  const dsp::Record r = dsp::read_data_file(o.data, columns, o.fs, 1000);
  models::MirrorFit fit = models::fit_mirror_model(r.column(o.input_col), r.column(o.current_col),
                                                   r.column(o.displacement_col), r.fs, o.max_delay);
  nlohmann::json meta = {{"data", o.data},
                         {"electrical_fit_pct", fit.electrical_fit_pct},
                         {"mechanical_fit_pct", fit.mechanical_fit_pct}};
  if (o.adapt) {
    if (fit.model.delay > models::MirrorObserver::kMaxDelay) {
      throw std::invalid_argument("design mirror --adapt: the fitted drive delay (" + std::to_string(fit.model.delay) +
                                  " samples) exceeds the observer's " + std::to_string(models::MirrorObserver::kMaxDelay));
    }
    const models::SensorMapFit sensor = models::fit_sensor_map(r.column(o.displacement_col), r.column(o.sensor_col), r.fs);
    models::MirrorObserverSettings& s = fit.model.observer;
    s.enabled = true;
    s.sensor_taps = sensor.taps;
    s.sensor_noise = sensor.noise_rms;
    s.process_noise = fit.mechanical_residual_rms;
    s.stiffness_rate = o.stiffness_rate;
    s.stiffness_spread = o.stiffness_spread;
    meta["sensor_map_residual_rms"] = sensor.noise_rms;
    std::fprintf(stderr, "design mirror: sensor map residual %.4g rms, adapting the stiffness on line\n", sensor.noise_rms);
  }
  models::write_json_file(o.out, models::mirror_model_to_json(fit.model, meta));
  std::fprintf(stderr, "design mirror: residual %.4f %% (electrical), %.4f %% (mechanical), delay %d samples\n",
               fit.electrical_fit_pct, fit.mechanical_fit_pct, fit.model.delay);
  print_result({{"out", o.out},
                {"fs", fit.model.fs},
                {"delay", fit.model.delay},
                {"friction_velocity_mm_per_s", fit.model.friction_velocity},
                {"electrical", fit.model.electrical},
                {"mechanical", fit.model.mechanical},
                {"electrical_fit_pct", fit.electrical_fit_pct},
                {"mechanical_fit_pct", fit.mechanical_fit_pct},
                {"adaptive", fit.model.observer.enabled}});
}

}  // namespace

void add_design_mirror(CLI::App& design) {
  auto o = std::make_shared<DesignMirrorOptions>();
  CLI::App* cmd = design.add_subcommand(
      "mirror", "Mirror filter: the exact inverse of a gray-box exciter model fitted to drive, current and displacement");
  cmd->add_option("--data", o->data, "Record (CSV or WAV) with the drive, coil current (A) and displacement (m)")
      ->required();
  cmd->add_option("--fs", o->fs, "Sample rate of a CSV record, Hz");
  cmd->add_option("--input-col", o->input_col, "Drive column")->capture_default_str();
  cmd->add_option("--current-col", o->current_col, "Coil current column, A")->capture_default_str();
  cmd->add_option("--displacement-col", o->displacement_col, "Displacement column, m")->capture_default_str();
  cmd->add_option("--max-delay", o->max_delay, "Largest drive-to-voltage delay searched, samples")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  cmd->add_flag("--adapt", o->adapt,
                "Adapt the stiffness on line from the sensor (an extended Kalman filter; fits the sensor map to the "
                "record's sensor column)");
  cmd->add_option("--sensor-col", o->sensor_col, "Sensor column read with --adapt")->capture_default_str();
  cmd->add_option("--stiffness-rate", o->stiffness_rate, "With --adapt: the stiffness scale's random walk per sample")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--stiffness-spread", o->stiffness_spread, "With --adapt: the stiffness scale's initial spread")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Model file to write (JSON, kind mirror_filter)")->required();
  cmd->footer(
      "Example:\n  panelbass simulate --plant panel-exciter --signal multisine --f-min 10 --f-max 300 --amplitude 0.5 "
      "--samples 30000 --out rec.csv\n"
      "  panelbass design mirror --data rec.csv --fs 3000 --out mirror.json\n"
      "  panelbass design mirror --data rec.csv --fs 3000 --adapt --out mirror-adaptive.json\n"
      "  panelbass chain --bandpass 0,1200 --ff mirror.json --out chain.json");
  cmd->callback([o] { run_design_mirror(*o); });
}

}  // namespace panelbass::cli

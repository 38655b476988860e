// `panelbass tune`: the tune use case (usecases/tune.h) on a simulated transducer — the same pipeline the
// server's tune job runs through its backend: measure, fit from the coil current, mirror filter, verify at equal
// output level, keep it only where it helps.

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "engine/chain_file.h"
#include "models/io/json_file.h"
#include "models/plant/plant_config.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "usecases/tune.h"

namespace panelbass::cli {
namespace {

// The options of `tune`; the defaults are the request's (usecases::TuneRequest).
struct TuneOptions {
  std::string plant = "panel-exciter";
  std::string chain;  // a chain file whose band-pass and limiter the filter runs behind
  bool quiet_sensor = false;
  usecases::TuneRequest request;
  std::string out;
  std::string report;
};

void run_tune(TuneOptions o) {
  models::PlantConfig plant = models::plant_from_name_or_file(o.plant);
  if (o.quiet_sensor) plant = models::without_sensor_noise(plant);
  usecases::TuneRequest& q = o.request;
  if (!o.chain.empty()) {
    q.chain = engine::load_chain_file(o.chain);
    if (q.chain.fs != plant.fs) {
      throw std::invalid_argument(o.chain + ": the chain runs at " + std::to_string(q.chain.fs) + " Hz, the plant at " +
                                  std::to_string(plant.fs) + " Hz");
    }
  } else {
    q.chain = engine::ChainConfig{};
    q.chain.fs = plant.fs;
  }
  // Each play a new stretch of the plant's sensor noise.
  std::uint64_t seed = q.seed + 1000;
  const usecases::PlayFunction play = [&plant, &seed](const Eigen::VectorXd& drive) {
    models::PlantRecord r = models::simulate(plant, drive, seed++);
    return usecases::Playback{std::move(r.y), std::move(r.i), Eigen::VectorXd(), nullptr};
  };
  BarProgress bar("tune");
  const usecases::TuneReport report = run_use_case(
      [&] { return usecases::tune(q, play, bar); },
      {{{"frequencies", "--probes"}}, {}});
  nlohmann::json result = report.to_json();
  result["plant"] = plant.name;
  result["summary"] = report.mirror->summary;
  print_warnings("tune", report.warnings);
  if (!o.report.empty()) models::write_json_file(o.report, result);
  if (report.keep && !o.out.empty()) {
    models::write_json_file(o.out, models::mirror_model_to_json(report.mirror->model, report.mirror->meta));
    result["out"] = o.out;
  }
  print_result(result);
  if (!report.keep) throw std::runtime_error(report.decision + " (no filter written)");
}

}  // namespace

void register_tune(CLI::App& app) {
  auto o = std::make_shared<TuneOptions>();
  usecases::TuneRequest& q = o->request;
  CLI::App* cmd = app.add_subcommand(
      "tune",
      "Cancel a transducer's distortion in one step, as the server's tune job does through its backend: measure it\n"
      "with a multisine, fit the gray-box model from the coil current alone (the back-EMF carries the motion), design\n"
      "the mirror filter, verify it at equal output level and keep it only where it cuts the THD. Exit 1 when left out");
  cmd->add_option("--plant", o->plant, "Preset or plant JSON file (the transducer simulated)")->capture_default_str();
  cmd->add_option("--chain", o->chain, "A chain file whose band-pass and limiter the filter runs behind (default 20-1200 Hz)");
  cmd->add_flag("--quiet-sensor", o->quiet_sensor, "Without the plant's sensor noise (THD read to the harmonics)");
  cmd->add_option("--samples", q.samples, "The measurement's multisine, samples")->capture_default_str();
  cmd->add_option("--amplitude", q.amplitude, "Its peak")->capture_default_str();
  cmd->add_option("--f-min", q.f_min, "Its lowest line, Hz")->capture_default_str();
  cmd->add_option("--f-max", q.f_max, "Its highest line, Hz")->capture_default_str();
  cmd->add_option("--seed", q.seed, "Its phases (and the sensor noise's seeds)")->capture_default_str();
  cmd->add_option("--sensor-kind", q.sensor_kind, "The sensor joins the fit: none, acceleration, velocity, displacement, microphone")
      ->capture_default_str();
  cmd->add_option("--max-delay", q.max_delay, "Largest drive-to-voltage delay searched, samples")->capture_default_str();
  cmd->add_option("--probes", q.verify.frequencies, "Verify's probe frequencies, Hz")->delimiter(',');
  cmd->add_option("--levels", q.verify.levels, "Verify's program sine amplitudes")->delimiter(',');
  cmd->add_option("--settle-seconds", q.verify.settle_seconds, "Before each analysis window")->capture_default_str();
  cmd->add_option("--analysis-seconds", q.verify.analysis_seconds, "Each analysis window")->capture_default_str();
  cmd->add_option("--max-plays", q.verify.max_plays, "Passes searching the plant-alone drive")->capture_default_str();
  cmd->add_option("--keep-min-cut-db", q.keep_min_cut_db, "Keep the filter when it cuts at least this somewhere")->capture_default_str();
  cmd->add_flag("!--no-refine", q.refine_friction,
                "Skip refitting the friction's velocity scale on the current's harmonics of two quiet sines");
  cmd->add_option("--out", o->out, "Write the kept mirror filter here");
  cmd->add_option("--report", o->report, "Write the whole report (steps, verify's points) here");
  cmd->footer(
      "Examples:\n  panelbass tune --plant panel-exciter --out mirror.json\n"
      "  panelbass tune --plant my-exciter.json --probes 80 --levels 0.2 --quiet-sensor --report tune.json\n"
      "  panelbass chain --bandpass 0,1200 --ff mirror.json --out chain.json");
  cmd->callback([o] { run_tune(*o); });
}

}  // namespace panelbass::cli

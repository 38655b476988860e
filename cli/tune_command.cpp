// `panelbass tune`: the tune use case (usecases/tune.h) through a backend (cli/backend_player.h: the simulated
// transducer or a sound card) — the same pipeline the server's tune job runs through its backend: measure, fit from
// the coil current, refine the friction, mirror filter, verify at equal output level, keep it only where it helps.

#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/backend_player.h"
#include "cli/measured_record.h"
#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "models/io/json_file.h"
#include "usecases/tune.h"

namespace panelbass::cli {
namespace {

// The options of `tune`; the defaults are the request's (usecases::TuneRequest).
struct TuneOptions {
  BackendOptions backend;
  std::string chain;  // a chain file whose band-pass and limiter the filter runs behind
  usecases::TuneRequest request;
  std::string out;
  std::string report;
  std::string record;  // the measurement's CSV
};

void run_tune(TuneOptions o, bool amplitude_given, bool levels_given) {
  usecases::TuneRequest& q = o.request;
  // On the virtual transducer no loopback, as the server's tune job plays it (api/jobs/backend_play.cpp): its
  // converters' loopback never wins the fit's choice of drive there (panel-exciter's current J_val 0.0093 % as sent
  // against 0.045 % from the loopback), and a second fit would only cost time. Each play a new stretch of its sensor noise.
  o.backend.virtual_loopback = false;
  BackendPlayer player(o.backend, q.seed + 1000);
  q.chain = player.chain(o.chain);
  // the defaults within the card's safe level, as the tune job has them; a level given above it is refused
  q.safe_level = player.safe_level();
  if (!amplitude_given) q.amplitude = std::min(q.amplitude, q.safe_level);
  if (!levels_given) {
    for (double& level : q.verify.levels) level = std::min(level, q.safe_level);
  }
  BarProgress bar("tune");
  const usecases::TuneReport report = run_use_case(
      [&] { return usecases::tune(q, player.play(), bar); },
      {{{"frequencies", "--probes"}}, {}});
  nlohmann::json result = report.to_json();
  result["fs"] = player.fs();
  result["backend"] = player.name();
  result["plant"] = player.plant().name;
  result["summary"] = report.mirror->summary;
  print_warnings("tune", report.warnings);
  if (!o.report.empty()) models::write_json_file(o.report, result);
  if (!o.record.empty()) {
    const usecases::Playback& m = report.measurement;
    write_measured_record(o.record, player.fs(), report.drive, m.sensor, m.current, Eigen::VectorXd(), m.loopback);
    result["record"] = o.record;
  }
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
  cmd->add_option("--chain", o->chain, "A chain file whose band-pass and limiter the filter runs behind (default 20-1200 Hz)");
  add_backend_options(cmd, o->backend);
  cmd->add_option("--samples", q.samples, "The measurement's multisine, samples")->capture_default_str();
  CLI::Option* amplitude = cmd->add_option("--amplitude", q.amplitude, "Its peak (at most the safe level)")->capture_default_str();
  cmd->add_option("--f-min", q.f_min, "Its lowest line, Hz")->capture_default_str();
  cmd->add_option("--f-max", q.f_max, "Its highest line, Hz")->capture_default_str();
  cmd->add_option("--seed", q.seed, "Its phases (and the sensor noise's seeds)")->capture_default_str();
  cmd->add_option("--sensor-kind", q.sensor_kind, "The sensor joins the fit: none, acceleration, velocity, displacement, microphone")
      ->capture_default_str();
  cmd->add_option("--max-delay", q.max_delay, "Largest drive-to-voltage delay searched, samples")->capture_default_str();
  cmd->add_option("--probes", q.verify.frequencies, "Verify's probe frequencies, Hz")->delimiter(',');
  CLI::Option* levels = cmd->add_option("--levels", q.verify.levels, "Verify's program sine amplitudes (at most the safe level)")->delimiter(',');
  cmd->add_option("--settle-seconds", q.verify.settle_seconds, "Before each analysis window")->capture_default_str();
  cmd->add_option("--analysis-seconds", q.verify.analysis_seconds, "Each analysis window")->capture_default_str();
  cmd->add_option("--max-plays", q.verify.max_plays, "Passes searching the plant-alone drive")->capture_default_str();
  cmd->add_option("--keep-min-cut-db", q.keep_min_cut_db, "Keep the filter when it cuts at least this somewhere")->capture_default_str();
  cmd->add_flag("!--no-refine", q.refine_friction,
                "Skip refitting the friction's velocity scale on the current's harmonics of two quiet sines");
  cmd->add_option("--out", o->out, "Write the kept mirror filter here");
  cmd->add_option("--report", o->report, "Write the whole report (steps, verify's points) here");
  cmd->add_option("--record", o->record,
                  "Write the measurement here (CSV: u the multisine as sent, i the current, y the sensor and l the loopback "
                  "where recorded), which design mirror --current-only reads again (with --input-col l from the loopback)");
  cmd->footer(
      "Examples:\n  panelbass tune --plant panel-exciter --out mirror.json\n"
      "  panelbass tune --plant my-exciter.json --probes 80 --levels 0.2 --quiet-sensor --report tune.json\n"
      "  panelbass tune --backend alsa --playback hw:1 --capture hw:1 --current-channel 2 --loopback-channel 0 \\\n"
      "      --safe-level 0.3 --probes 80 --out mirror.json\n"
      "  panelbass chain --bandpass 0,1200 --ff mirror.json --out chain.json");
  cmd->callback([o, amplitude, levels] { run_tune(*o, amplitude->count() > 0, levels->count() > 0); });
}

}  // namespace panelbass::cli

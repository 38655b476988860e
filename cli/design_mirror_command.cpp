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
#include "cli/usecase_door.h"
#include "dsp/data_file.h"
#include "models/control/mirror_filter.h"
#include "models/control/mirror_observer.h"
#include "models/io/json_file.h"
#include "usecases/design_mirror.h"

namespace panelbass::cli {
namespace {

// The options of `design mirror`; the defaults are the request's (usecases::DesignMirrorRequest).
struct DesignMirrorOptions {
  std::string data, out;
  double fs = 0.0;
  std::string input_col = "u", current_col = "i", displacement_col = "x", sensor_col = "y";
  bool current_only = usecases::DesignMirrorRequest{}.current_only;
  bool sensor_given = false;  // --sensor-col on the command line: with --current-only the sensor joins the fit
  std::string sensor_kind = "acceleration";
  int max_delay = usecases::DesignMirrorRequest{}.max_delay;
  bool adapt = usecases::DesignMirrorRequest{}.adapt;
  double stiffness_rate = usecases::DesignMirrorRequest{}.stiffness_rate;
  double stiffness_spread = usecases::DesignMirrorRequest{}.stiffness_spread;
};

void run_design_mirror(const DesignMirrorOptions& o) {
  const bool joins = o.current_only && o.sensor_given;
  std::vector<std::string> columns{o.input_col, o.current_col};
  if (!o.current_only) columns.push_back(o.displacement_col);
  const bool sensor_read = (o.adapt && !o.current_only) || joins;  // with --current-only, --adapt reads the current
  if (sensor_read) columns.push_back(o.sensor_col);
  const dsp::Record r = dsp::read_data_file(o.data, columns, o.fs, 1000);
  usecases::DesignMirrorRequest q;
  q.drive = r.column(o.input_col);
  q.current = r.column(o.current_col);
  if (!o.current_only) q.displacement = r.column(o.displacement_col);
  if (sensor_read) q.sensor = r.column(o.sensor_col);
  q.current_only = o.current_only;
  if (joins) q.sensor_kind = o.sensor_kind;
  q.fs = r.fs;
  q.data_name = o.data;
  q.max_delay = o.max_delay;
  q.adapt = o.adapt;
  q.stiffness_rate = o.stiffness_rate;
  q.stiffness_spread = o.stiffness_spread;
  BarProgress progress("design mirror");
  const usecases::DesignMirrorReport report = run_use_case([&] { return usecases::design_mirror(q, progress); },
                                                           {{{"fs", "--fs"}, {"sensor_kind", "--sensor-kind"}},
                                                            {{"record", o.data}}});
  print_warnings("design mirror", report.warnings);
  if (!report.usable) {
    throw std::runtime_error("design mirror: the fit misses the record (current J_val " +
                             report.summary.at("current_j_val_pct").dump() + " %); no model written to " + o.out);
  }
  models::write_json_file(o.out, models::mirror_model_to_json(report.model, report.meta));
  if (o.current_only) {
    std::fprintf(stderr, "design mirror: current J %.4f %% (fit), %.4f %% (validation; linear %.4f %%), lag %d samples\n",
                 report.summary.at("current_j_fit_pct").get<double>(), report.summary.at("current_j_val_pct").get<double>(),
                 report.summary.at("linear_current_j_val_pct").get<double>(), report.summary.at("current_lag").get<int>());
  } else {
    std::fprintf(stderr, "design mirror: residual %.4f %% (electrical), %.4f %% (mechanical), delay %d samples\n",
                 report.summary.at("electrical_fit_pct").get<double>(), report.summary.at("mechanical_fit_pct").get<double>(),
                 report.model.delay);
  }
  nlohmann::json result = report.summary;
  result["out"] = o.out;
  result["warnings"] = report.warnings;
  print_result(result);
}

}  // namespace

void add_design_mirror(CLI::App& design) {
  auto o = std::make_shared<DesignMirrorOptions>();
  CLI::App* cmd = design.add_subcommand(
      "mirror", "Mirror filter: the exact inverse of a gray-box exciter model fitted to drive, current and displacement");
  cmd->add_option("--data", o->data, "Record (CSV or WAV) with the drive, coil current (A) and displacement (m; not with --current-only)")
      ->required();
  cmd->add_option("--fs", o->fs, "Sample rate of a CSV record, Hz");
  cmd->add_option("--input-col", o->input_col, "Drive column")->capture_default_str();
  cmd->add_option("--current-col", o->current_col, "Coil current column, A")->capture_default_str();
  cmd->add_option("--displacement-col", o->displacement_col, "Displacement column, m")->capture_default_str();
  cmd->add_option("--max-delay", o->max_delay, "Largest drive-to-voltage delay searched, samples")
      ->capture_default_str();
  cmd->add_flag("--adapt", o->adapt,
                "Adapt the stiffness on line from the sensor (an extended Kalman filter; fits the sensor map to the "
                "record's sensor column); with --current-only, adapt the coil's resistance, Bl(x), K(x) and the "
                "nonlinear shapes' scale from the coil current (the chain's measured input must then be the current)");
  cmd->add_flag("--current-only", o->current_only,
                "Fit from the drive and the coil current alone, as a sound card records them (the motion from the "
                "back-EMF; no displacement column read). The friction's refine on sines (tune's) is not run: it "
                "plays sines, and this verb only reads a record; the friction's refine needs a backend: use tune");
  CLI::Option* sensor_col = cmd->add_option("--sensor-col", o->sensor_col,
                                            "Sensor column, read with --adapt; given with --current-only, the sensor "
                                            "joins the fit (its scale, sign and delay fitted)")
                                ->capture_default_str();
  cmd->add_option("--sensor-kind", o->sensor_kind,
                  "What --sensor-col measures with --current-only: acceleration, velocity, displacement or microphone")
      ->capture_default_str();
  cmd->add_option("--stiffness-rate", o->stiffness_rate, "With --adapt: the stiffness scale's random walk per sample")
      ->capture_default_str();
  cmd->add_option("--stiffness-spread", o->stiffness_spread, "With --adapt: the stiffness scale's initial spread")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Model file to write (JSON, kind mirror_filter)")->required();
  cmd->footer(
      "Example:\n  panelbass simulate --plant panel-exciter --signal multisine --f-min 10 --f-max 300 --amplitude 0.5 "
      "--samples 30000 --out rec.csv\n"
      "  panelbass design mirror --data rec.csv --fs 3000 --out mirror.json\n"
      "  panelbass design mirror --data rec.csv --fs 3000 --adapt --out mirror-adaptive.json\n"
      "  panelbass design mirror --data rec.csv --fs 3000 --current-only --out mirror-current.json\n"
      "  panelbass chain --bandpass 0,1200 --ff mirror.json --out chain.json");
  cmd->callback([o, sensor_col] {
    o->sensor_given = sensor_col->count() > 0;
    run_design_mirror(*o);
  });
}

}  // namespace panelbass::cli

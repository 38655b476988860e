// `panelbass design mirror`: Klippel's mirror filter fitted to a record of drive, coil current and
// displacement (models/control/mirror_filter.h) — the gray-box physics of the exciter from identification
// data alone, written as a model file the chain runs as its feedforward stage.
#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "dsp/data_file.h"
#include "models/control/mirror_filter.h"
#include "models/io/json_file.h"

namespace panelbass::cli {
namespace {

struct DesignMirrorOptions {
  std::string data, out;
  double fs = 0.0;
  std::string input_col = "u", current_col = "i", displacement_col = "x";
  int max_delay = 4;
};

void run_design_mirror(const DesignMirrorOptions& o) {
  const dsp::Record r = dsp::read_data_file(o.data, {o.input_col, o.current_col, o.displacement_col}, o.fs, 1000);
  const models::MirrorFit fit = models::fit_mirror_model(r.column(o.input_col), r.column(o.current_col),
                                                         r.column(o.displacement_col), r.fs, o.max_delay);
  const nlohmann::json meta = {{"data", o.data},
                               {"electrical_fit_pct", fit.electrical_fit_pct},
                               {"mechanical_fit_pct", fit.mechanical_fit_pct}};
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
                {"mechanical_fit_pct", fit.mechanical_fit_pct}});
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
  cmd->add_option("--out", o->out, "Model file to write (JSON, kind mirror_filter)")->required();
  cmd->footer(
      "Example:\n  panelbass simulate --plant panel-exciter --signal multisine --f-min 10 --f-max 300 --amplitude 0.5 "
      "--samples 30000 --out rec.csv\n"
      "  panelbass design mirror --data rec.csv --fs 3000 --out mirror.json\n"
      "  panelbass chain --bandpass 0,1200 --ff mirror.json --out chain.json");
  cmd->callback([o] { run_design_mirror(*o); });
}

}  // namespace panelbass::cli

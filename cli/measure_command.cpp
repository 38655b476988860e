// `panelbass measure`: the excitation use case (usecases/excite.h) through a backend — the virtual transducer, or a
// sound card by the card measurement protocol the server's excite job measures with — and the record written as the
// CSV files the identify verbs read (an estimation part and a validation part).

#include <algorithm>
#include <memory>
#include <string>

#include "cli/backend_player.h"
#include "cli/commands.h"
#include "cli/measured_record.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "dsp/data_file.h"
#include "models/io/json_file.h"
#include "usecases/excite.h"

namespace panelbass::cli {
namespace {

// The options of `measure`; the defaults are the request's (usecases::ExciteRequest).
struct MeasureOptions {
  BackendOptions backend;
  usecases::ExciteRequest request;
  std::string ff;  // control: the LQ feedforward whose drive is played
  std::string out, val_out;
};

void run_measure(MeasureOptions o, bool amplitude_given) {
  usecases::ExciteRequest& q = o.request;
  if (q.validation_samples > 0 && o.val_out.empty()) {
    throw CLI::ValidationError("--val-out", "the validation part (--validation-samples " + std::to_string(q.validation_samples) +
                                                ") needs a file; or --validation-samples 0");
  }
  BackendPlayer player(o.backend, q.seed + 1000);
  q.fs = player.fs();
  q.safe_level = player.safe_level();
  if (!amplitude_given) q.amplitude = std::min(q.amplitude, q.safe_level);
  if (!o.ff.empty()) {
    q.feedforward_model = models::read_json_file(o.ff);
    q.feedforward_name = o.ff;
  }
  BarProgress bar("measure");
  const usecases::ExciteReport report = run_use_case([&] { return usecases::excite(q, player.play(), bar); },
                                                     {{{"feedforward_model", "--ff"}}, {{"feedforward_model", o.ff}}});
  const usecases::ExcitationRecord& r = report.record;
  write_measured_record(o.out, q.fs, r.u_est, r.y_est, r.i_est, r.w_est, r.l_est);
  if (r.u_val.size() > 0) write_measured_record(o.val_out, q.fs, r.u_val, r.y_val, r.i_val, r.w_val, r.l_val);
  nlohmann::json result = report.summary;
  result["backend"] = player.name();
  result["plant"] = player.plant().name;
  result["out"] = o.out;
  result["val_out"] = r.u_val.size() > 0 ? nlohmann::json(o.val_out) : nlohmann::json(nullptr);
  if (!r.card.is_null()) result["card"] = r.card;
  print_result(result);
}

}  // namespace

void register_measure(CLI::App& app) {
  auto o = std::make_shared<MeasureOptions>();
  usecases::ExciteRequest& q = o->request;
  CLI::App* cmd = app.add_subcommand(
      "measure",
      "Measure a record through a backend, as the server's excite job does: noise, a multisine or a controller's drive\n"
      "played through the virtual transducer or a sound card (a calibration sweep before and after, the round trip\n"
      "removed, a slipped measurement played again), written as the CSV files the identify verbs read");
  add_backend_options(cmd, o->backend);
  cmd->add_option("--signal", q.signal, "noise, multisine, or control (the --ff controller's drive for a feedback design's program)")
      ->capture_default_str();
  cmd->add_option("--samples", q.samples, "The estimation part, samples")->capture_default_str();
  cmd->add_option("--validation-samples", q.validation_samples, "The validation part, samples (0: none)")->capture_default_str();
  CLI::Option* amplitude = cmd->add_option("--amplitude", q.amplitude, "The drive's peak (at most the safe level)")
                               ->capture_default_str();
  cmd->add_option("--seed", q.seed, "The estimation part's seed (the validation part's: seed + 1)")->capture_default_str();
  cmd->add_option("--ff", o->ff, "--signal control: the LQ feedforward controller (design lq)");
  cmd->add_option("--sine-peak", q.sine_peak, "--signal control: the stepped sines' peak")->capture_default_str();
  cmd->add_option("--program-share", q.program_share, "--signal control: their share at a program level")->capture_default_str();
  cmd->add_option("--out", o->out, "The estimation part's CSV (u, y; i, w, l where recorded)")->required();
  cmd->add_option("--val-out", o->val_out, "The validation part's CSV");
  cmd->footer(
      "Examples:\n  panelbass measure --backend virtual --plant panel-exciter --out est.csv --val-out val.csv\n"
      "  panelbass identify linear --data est.csv --val val.csv --fs 3000 --out lin.json\n"
      "  panelbass measure --backend alsa --playback hw:1 --capture hw:1 --sensor-channel 1 --loopback-channel 0 \\\n"
      "      --plant panel-exciter --safe-level 0.3 --out est.csv --val-out val.csv");
  cmd->callback([o, amplitude] { run_measure(*o, amplitude->count() > 0); });
}

}  // namespace panelbass::cli

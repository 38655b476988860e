// `panelbass verify`: the verify use case (usecases/verify.h) through a backend — the controllers' chain played
// through the virtual transducer or a sound card and compared with the transducer alone at equal output level, as
// the server's verify job does (and the tune's verify step on the filter it fitted).

#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/backend_player.h"
#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "models/io/json_file.h"
#include "usecases/verify.h"

namespace panelbass::cli {
namespace {

// The options of `verify`; the defaults are the request's (usecases::VerifyRequest).
struct VerifyOptions {
  BackendOptions backend;
  std::string ff, fb;
  std::string chain;  // a chain file whose band-pass and limiter the controllers run in
  std::uint64_t seed = 1;
  usecases::VerifyRequest request;
  std::string report;
};

void run_verify(VerifyOptions o, bool levels_given) {
  BackendPlayer player(o.backend, o.seed + 1000);
  usecases::VerifyRequest& q = o.request;
  q.feedforward_model = models::read_json_file(o.ff);
  q.feedforward_name = o.ff;
  if (!o.fb.empty()) {
    q.feedback_model = models::read_json_file(o.fb);
    q.feedback_name = o.fb;
  }
  q.chain = player.chain(o.chain);
  q.safe_level = player.safe_level();
  if (!levels_given) {
    for (double& level : q.settings.levels) level = std::min(level, q.safe_level);
  }
  BarProgress bar("verify");
  const usecases::EqualOutputReport report = run_use_case(
      [&] { return usecases::verify(q, player.play(), bar); },
      {{{"frequencies", "--probes"}, {"feedforward_model", "--ff"}, {"feedback_model", "--fb"}},
       {{"feedforward_model", o.ff}, {"feedback_model", o.fb}}});
  print_warnings("verify", report.warnings);
  nlohmann::json result = report.to_json();
  result["fs"] = player.fs();
  result["backend"] = player.name();
  result["plant"] = player.plant().name;
  if (!o.report.empty()) {
    nlohmann::json whole = result;
    whole["plots"] = report.plots();
    models::write_json_file(o.report, whole);
  }
  print_result(result);
}

}  // namespace

void register_verify(CLI::App& app) {
  auto o = std::make_shared<VerifyOptions>();
  usecases::EqualOutputSettings& s = o->request.settings;
  CLI::App* cmd = app.add_subcommand(
      "verify",
      "Verify controllers through a backend at equal output level, as the server's verify job does: probe sines played\n"
      "through the chain with the controllers, then the transducer alone driven to the same output; the THD cut is\n"
      "what the chain buys at the level a listener hears");
  cmd->add_option("--ff", o->ff, "The feedforward controller (design lq, design mirror, tune)")->required();
  cmd->add_option("--fb", o->fb, "A neural feedback controller (design nn), run in model mode");
  cmd->add_option("--chain", o->chain, "A chain file whose band-pass and limiter the controllers run in (default 20-1200 Hz)");
  add_backend_options(cmd, o->backend);
  cmd->add_option("--seed", o->seed, "Virtual backend: the sensor noise's seeds")->capture_default_str();
  cmd->add_option("--probes", s.frequencies, "Probe frequencies, Hz")->delimiter(',')->capture_default_str();
  CLI::Option* levels =
      cmd->add_option("--levels", s.levels, "Program sine amplitudes (at most the safe level)")->delimiter(',')->capture_default_str();
  cmd->add_option("--settle-seconds", s.settle_seconds, "Before each analysis window")->capture_default_str();
  cmd->add_option("--analysis-seconds", s.analysis_seconds, "Each analysis window")->capture_default_str();
  cmd->add_option("--max-plays", s.max_plays, "Passes searching the plant-alone drive")->capture_default_str();
  cmd->add_option("--report", o->report, "Write the whole report (its points and the THD-against-level plots) here");
  cmd->footer(
      "Examples:\n  panelbass verify --ff mirror.json --backend virtual --plant panel-exciter --probes 80 --levels 0.2\n"
      "  panelbass verify --ff ff.json --fb fb.json --probes 40,80,160 --levels 0.1,0.2 --report verify.json\n"
      "  panelbass verify --ff mirror.json --backend alsa --playback hw:1 --capture hw:1 --sensor-channel 1 \\\n"
      "      --loopback-channel 0 --safe-level 0.3 --probes 80");
  cmd->callback([o, levels] { run_verify(*o, levels->count() > 0); });
}

}  // namespace panelbass::cli

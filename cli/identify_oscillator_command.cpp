// `panelbass identify oscillator`: a continuous-time oscillator with named nonlinear terms, fitted by its
// simulation error (models/oscillator).

#include <chrono>
#include <cstdio>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "cli/progress_bar.h"
#include "cli/stop_signals.h"
#include "cli/usecase_door.h"
#include "models/kinds/model_file.h"
#include "models/oscillator/oscillator_fit.h"
#include "usecases/identify_oscillator.h"

namespace panelbass::cli {
namespace {

// The options of `identify oscillator`; the defaults are the request's (usecases::IdentifyOscillatorRequest).
struct IdentifyOscillatorOptions {
  std::string data, val, out, terms = "y3";
  DataOptions columns;
  int substeps = usecases::IdentifyOscillatorRequest{}.substeps;
  int output_taps = usecases::IdentifyOscillatorRequest{}.output_taps;
  int input_taps = usecases::IdentifyOscillatorRequest{}.input_taps;
  int max_iterations = usecases::IdentifyOscillatorRequest{}.max_iterations;
  long init = usecases::IdentifyOscillatorRequest{}.init;
  bool no_delay = !usecases::IdentifyOscillatorRequest{}.delay;
};

/// The names of a comma-separated list ("y3,v_log_v"); an empty list has none.
std::vector<std::string> parse_terms(const std::string& list) {
  std::vector<std::string> names;
  std::stringstream stream(list);
  std::string name;
  while (std::getline(stream, name, ',')) {
    if (!name.empty()) names.push_back(name);
  }
  return names;
}

void run_identify_oscillator(const IdentifyOscillatorOptions& o) {
  usecases::IdentifyOscillatorRequest q;
  o.columns.read_into(q, o.data, o.val);
  q.terms = parse_terms(o.terms);
  q.substeps = o.substeps;
  q.output_taps = o.output_taps;
  q.input_taps = o.input_taps;
  q.max_iterations = o.max_iterations;
  q.init = o.init;
  q.delay = !o.no_delay;
  StoppableBarProgress progress("identify oscillator");
  const usecases::IdentifyOscillatorReport report = run_use_case(
      [&] { return usecases::identify_oscillator(q, progress); },
      {{{"max_iterations", "--max-iter"}, {"delay", "--no-delay"}, {"record", "--data"}}, {}});
  for (const nlohmann::json& s : report.summary.at("stages")) {
    std::fprintf(stderr, "identify oscillator: stage %-8s %3d steps, J_est %s %%, J_val %s %%, %.1f s\n",
                 s.at("stage").get<std::string>().c_str(), s.at("iterations").get<int>(), s.at("J_est_pct").dump().c_str(),
                 s.at("J_val_pct").dump().c_str(), s.at("seconds").get<double>());
  }
  for (const std::string& w : report.warnings) std::fprintf(stderr, "identify oscillator: warning: %s\n", w.c_str());
  models::save_oscillator_model(o.out, report.model);
  nlohmann::json result = report.summary;
  result["warnings"] = report.warnings;
  result["out"] = o.out;
  print_result(result);
}

}  // namespace

void register_identify_oscillator(CLI::App& identify) {
  auto o = std::make_shared<IdentifyOscillatorOptions>();
  CLI::App* cmd = identify.add_subcommand(
      "oscillator",
      "Continuous-time oscillator (a mass on a nonlinear spring and damper, driven by the band-limited input), "
      "fitted by its simulation error");
  cmd->add_option("--data", o->data, "Estimation data, .csv or .wav")->required();
  cmd->add_option("--val", o->val, "Validation data (chooses the stage, and J_val)");
  o->columns.add_to(cmd);
  cmd->add_option("--terms", o->terms,
                  "Terms of the restoring force beyond k·y and d·v, comma-separated, each freed in its own stage in this "
                  "order: y2, y3 (cubic spring), y_abs_y, v_log_v (v·ln|v| damping), y_v, v2, y_v2, v_y2; '' for none")
      ->capture_default_str();
  cmd->add_option("--output-taps", o->output_taps, "Taps h_1..h_L of the output filter (gain 1 at DC), a final stage")
      ->capture_default_str();
  cmd->add_option("--input-taps", o->input_taps, "Taps b_0..b_(M-1) of the input added to the output, with the output taps")
      ->capture_default_str();
  cmd->add_option("--substeps", o->substeps, "Runge-Kutta steps per sample")->capture_default_str();
  cmd->add_flag("--no-delay", o->no_delay, "Hold the input delay at 0 (by default it is fitted from the first term on)");
  cmd->add_option("--max-iter", o->max_iterations, "Levenberg-Marquardt iterations per stage")
      ->capture_default_str();
  cmd->add_option("--init", o->init, "Measured samples that set the state before J (the J reported and chosen on)")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Model file to write")->required();
  cmd->footer(
      "Example (the Silverbox, docs/identification.md):\n"
      "  panelbass identify oscillator --data est.csv --val val.csv --fs 610.3515625 "
      "--terms y3,v_log_v,y_v,v2,y_v2,y_abs_y,v_y2 --output-taps 8 --input-taps 8 --out oscillator.json\n"
      "  panelbass validate --model oscillator.json --data test.csv --fs 610.3515625 --init 50");
  cmd->callback([o] { run_identify_oscillator(*o); });
}

}  // namespace panelbass::cli

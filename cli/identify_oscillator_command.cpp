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
#include "models/io/json_fields.h"
#include "models/kinds/model_file.h"
#include "models/linear/fit_warnings.h"
#include "models/oscillator/oscillator_fit.h"

namespace panelbass::cli {
namespace {

/// Above this simulation J (%) a fit is called out as missing what the output does.
constexpr double kUsefulJPct = 10.0;

struct IdentifyOscillatorOptions {
  std::string data, val, out, terms = "y3";
  DataOptions columns;
  int substeps = 4, output_taps = 0, input_taps = 0, max_iterations = 200;
  long init = 50;
  bool no_delay = false;
};

/// The terms of a comma-separated list ("y3,v_log_v"); an empty list has none.
std::vector<models::OscillatorTerm> parse_terms(const std::string& list) {
  std::vector<models::OscillatorTerm> terms;
  std::stringstream stream(list);
  std::string name;
  while (std::getline(stream, name, ',')) {
    if (name.empty()) continue;
    try {
      terms.push_back(models::oscillator_term_from_name(name));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("--terms: " + std::string(e.what()));
    }
  }
  return terms;
}

void run_identify_oscillator(const IdentifyOscillatorOptions& o) {
  const dsp::Record est = o.columns.read(o.data);
  const DataOptions::Validation val = o.columns.read_optional_validation(o.val, est.fs);
  const Eigen::VectorXd &u_val = val.u, &y_val = val.y;
  models::OscillatorFitOptions options;
  options.structure.terms = parse_terms(o.terms);
  options.structure.substeps = o.substeps;
  options.structure.output_taps = o.output_taps;
  options.structure.input_taps = o.input_taps;
  try {
    options.structure.check();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("--terms: " + std::string(e.what()));
  }
  options.delay = !o.no_delay;
  options.max_iterations = o.max_iterations;
  options.init = o.init;
  const StopSignals stop;
  ProgressBar bar("identify oscillator");
  options.progress = [&](const models::OscillatorFitProgress& p) {
    bar.update((static_cast<double>(p.stage_number) + static_cast<double>(p.iteration) / o.max_iterations) /
               static_cast<double>(p.stages));
    return !stop_requested();
  };
  models::OscillatorFit fit = models::fit_oscillator(est.columns[0], est.columns[1], u_val, y_val, est.fs, options);
  bar.update(1.0);
  nlohmann::json stages = nlohmann::json::array();
  for (const models::OscillatorStage& s : fit.stages) {
    std::fprintf(stderr, "identify oscillator: stage %-8s %3d steps, J_est %.5g %%, J_val %.5g %%, %.1f s\n", s.name.c_str(),
                 s.iterations, s.j_est_pct, s.j_val_pct, s.seconds);
    stages.push_back({{"stage", s.name},
                      {"iterations", s.iterations},
                      {"J_est_pct", models::number_or_null(s.j_est_pct)},
                      {"J_val_pct", models::number_or_null(s.j_val_pct)},
                      {"seconds", s.seconds}});
  }
  const models::OscillatorStage& best = fit.stages[fit.best_stage];
  // A fit worse than a linear model of its own order (2) on the same part says so (fit_warnings).
  const bool validated = u_val.size() > 0;
  const double j_linear = models::linear_reference_j_pct(est.columns[0], est.columns[1], u_val, y_val, 2, 0, o.init);
  std::vector<std::string> warnings = models::fit_warnings(
      validated ? best.j_val_pct : best.j_est_pct, validated ? "J_val" : "J_est", j_linear,
      "The record may not be one mass on a spring (more resonances, a coil's inductance, a sensor that differentiates): "
      "try identify linear, narx or ss, or more --terms and --output-taps/--input-taps.");
  const double j_judged = validated ? best.j_val_pct : best.j_est_pct;
  if (warnings.empty() && j_judged > kUsefulJPct) {
    char figure[64];
    std::snprintf(figure, sizeof figure, "%.3g", j_judged);
    warnings.push_back(std::string(validated ? "J_val" : "J_est") + " = " + figure +
                       " %: the oscillator misses more than a tenth of the output's energy. The record may not be one "
                       "mass on a spring (more resonances, a coil's inductance, a sensor that differentiates): try "
                       "identify linear, narx or ss, or more --terms and --output-taps/--input-taps.");
  }
  for (const std::string& w : warnings) std::fprintf(stderr, "identify oscillator: warning: %s\n", w.c_str());
  fit.model.meta = {{"data", o.data},
                    {"val", o.val},
                    {"init", o.init},
                    {"J_est_pct", models::number_or_null(best.j_est_pct)},
                    {"J_val_pct", models::number_or_null(best.j_val_pct)},
                    {"chosen_stage", best.name},
                    {"stages", stages},
                    {"seconds", fit.stages.back().seconds}};
  models::save_oscillator_model(o.out, fit.model);
  print_result({{"J_est_pct", models::number_or_null(best.j_est_pct)},
                {"J_val_pct", models::number_or_null(best.j_val_pct)},
                {"chosen_stage", best.name},
                {"stages", stages},
                {"warnings", warnings},
                {"params", fit.model.theta.size()},
                {"seconds", fit.stages.back().seconds},
                {"out", o.out}});
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
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  cmd->add_option("--input-taps", o->input_taps, "Taps b_0..b_(M-1) of the input added to the output, with the output taps")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  cmd->add_option("--substeps", o->substeps, "Runge-Kutta steps per sample")->check(CLI::Range(1, 64))->capture_default_str();
  cmd->add_flag("--no-delay", o->no_delay, "Hold the input delay at 0 (by default it is fitted from the first term on)");
  cmd->add_option("--max-iter", o->max_iterations, "Levenberg-Marquardt iterations per stage")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_option("--init", o->init, "Measured samples that set the state before J (the J reported and chosen on)")
      ->check(CLI::Range(0L, 100000000L))
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

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/evaluation_plots.h"
#include "cli/gnuplot.h"
#include "cli/html_report.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "engine/chain_file.h"
#include "models/io/json_file.h"
#include "models/plant/plant_presets.h"
#include "usecases/evaluate.h"

namespace panelbass::cli {
namespace {

// The options of `evaluate`; the defaults are the request's (usecases::EvaluateRequest).
struct EvaluateOptions {
  std::string chain, out, plots, html;
  std::string plot_format = "png";
  usecases::EvaluateRequest q;  ///< the flags' values (chain and plant filled in by run_evaluate)
};

// The level sweep on stderr: per probe and level, the output level, THD of the chain and of the plant alone at
// that level, and the cut; a level the chain cannot reach undistorted by its limiter is marked.
void print_level_sweep(const evaluation::LevelSweep& sweep) {
  std::fprintf(stderr, "THD at equal output level (sensor fundamental), chain vs plant alone:\n");
  std::fprintf(stderr, "%7s %8s %10s %10s %10s %9s %9s %8s\n", "f Hz", "program", "output V", "chain %", "plant %",
               "cut dB", "floor %", "drive");
  for (const evaluation::LevelCurve& c : sweep.curves) {
    for (const evaluation::LevelPoint& p : c.points) {
      std::fprintf(stderr, "%7.0f %8.3f %10.4f %10.3f %10.3f %9.1f %9.3f %8.3f%s", c.frequency_hz, p.program_amplitude,
                   p.chain.fundamental, p.chain.thd_pct, p.plant.thd_pct, p.cut_db, p.noise_floor_pct, p.chain.drive_peak,
                   p.reachable ? "" : "  (not reachable)");
      if (p.needs_more_drive) {
        std::fprintf(stderr, "  needs more drive than the chain can give (asked %.3f)", p.peak_demand);
      }
      std::fprintf(stderr, "\n");
    }
    std::fprintf(stderr, "%7.0f worst cut over the reachable levels: %.1f dB\n", c.frequency_hz,
                 sweep.worst_cut_db(c.frequency_hz));
  }
  std::fprintf(stderr, "two-tone IMD: program  chain %%  plant %%  cut dB\n");
  for (const evaluation::ImdPoint& p : sweep.imd) {
    std::fprintf(stderr, "            %8.3f %8.3f %8.3f %7.1f%s\n", p.program_amplitude, p.chain_imd_pct, p.plant_imd_pct,
                 p.cut_db, p.reachable ? "" : "  (not reachable)");
  }
}

// The level sweep as an HTML page: the THD-versus-level chart and the table of cuts.
void write_sweep_html(const std::string& path, const std::string& chain, const std::string& plant,
                      const evaluation::LevelSweep& sweep, const std::filesystem::path& figure, PlotFormat format) {
  std::string body = "<h1>Distortion at equal output level</h1><p>chain " + html_escaped(chain) + " on plant " +
                     html_escaped(plant) +
                     ": THD against the fundamental at the sensor (an independent DFT), the chain beside the plant "
                     "driven alone at the drive that gives the same fundamental.</p>";
  body += html_figures({{"thd_vs_level", "THD against the output level: chain (solid), plant alone (dashed)", figure}}, format);
  body += "<table><tr><th>f (Hz)</th><th>program</th><th>output (V)</th><th>THD chain (%)</th><th>THD plant (%)</th>"
          "<th>cut (dB)</th><th>noise floor (%)</th><th>reachable</th></tr>";
  for (const evaluation::LevelCurve& c : sweep.curves) {
    for (const evaluation::LevelPoint& p : c.points) {
      body += "<tr><td>" + html_cell(c.frequency_hz) + "</td><td>" + html_cell(p.program_amplitude) + "</td><td>" +
              html_cell(p.chain.fundamental) + "</td><td>" + html_cell(p.chain.thd_pct) + "</td><td>" +
              html_cell(p.plant.thd_pct) + "</td><td>" + html_cell(p.cut_db, 3) + "</td><td>" +
              html_cell(p.noise_floor_pct) + "</td><td>" + html_cell(p.reachable) + "</td></tr>";
    }
  }
  body += "</table>";
  write_html_page(path, "panelbass evaluate: THD against level", body);
}

// The table a person reads, on stderr: ripple and J_c of the transducer's output, and (on a plant whose
// sensor is noisy) as the sensor measures them.
void print_table(const evaluation::ChainEvaluation& e) {
  std::fprintf(stderr, "%-36s %9s %8s", "configuration", "ripple dB", "J_c %");
  for (const evaluation::ProbeResult& p : e.rows.front().probes) std::fprintf(stderr, "  THD@%-4.0f%%", p.frequency_hz);
  std::fprintf(stderr, "  max|drive|  rest|drive|\n");
  for (const evaluation::EvaluationRow& row : e.rows) {
    std::fprintf(stderr, "%-36s %9.2f %8.2f", row.name.c_str(), row.ripple_db, row.jc_pct);
    for (const evaluation::ProbeResult& p : row.probes) std::fprintf(stderr, "  %9.2f", p.thd_pct);
    std::fprintf(stderr, "  %10.3f  %11.4f\n", row.max_drive, row.rest_drive_peak);
    if (e.jc_noise_floor_pct > 0.0) {
      std::fprintf(stderr, "%-36s %9.2f %8.2f\n", "  (through the noisy sensor)", row.measured_ripple_db,
                   row.measured_jc_pct);
    }
    if (!row.probes.empty() && std::isfinite(row.probes.front().model_thd_pct)) {
      std::fprintf(stderr, "%-36s %9s %8s", "  (the design's plant model)", "", "");
      for (const evaluation::ProbeResult& p : row.probes) std::fprintf(stderr, "  %9.2f", p.model_thd_pct);
      std::fprintf(stderr, "\n");
    }
  }
}

// Each nonlinear term's THD per probe behind band-pass + feedforward (what a feedback stage is there to
// remove), on stderr, with the whole plant's first: its row of the same name as the terms' last.
void print_attribution(const evaluation::ChainEvaluation& whole, const std::vector<evaluation::TermDistortion>& terms) {
  if (terms.empty()) {
    std::fprintf(stderr, "which term makes the distortion: the plant has no nonlinear term switched on\n");
    return;
  }
  const std::string& compared = terms.front().rows.back().name;
  const auto same_name = [&](const evaluation::EvaluationRow& r) { return r.name == compared; };
  const auto found = std::find_if(whole.rows.begin(), whole.rows.end(), same_name);
  if (found == whole.rows.end()) throw std::logic_error("the evaluation has no \"" + compared + "\" row");
  const evaluation::EvaluationRow& row = *found;
  std::fprintf(stderr, "which term makes the distortion (%s, THD %% with that term alone on):\n", row.name.c_str());
  std::fprintf(stderr, "%-14s", "term");
  for (const evaluation::ProbeResult& p : row.probes) std::fprintf(stderr, "  THD@%-4.0f%%", p.frequency_hz);
  std::fprintf(stderr, "\n%-14s", "(all)");
  for (const evaluation::ProbeResult& p : row.probes) std::fprintf(stderr, "  %9.3f", p.thd_pct);
  for (const evaluation::TermDistortion& t : terms) {
    std::fprintf(stderr, "\n%-14s", t.term.c_str());
    for (const evaluation::ProbeResult& p : t.rows.back().probes) std::fprintf(stderr, "  %9.3f", p.thd_pct);
  }
  std::fprintf(stderr, "\n");
}

void run_evaluate(EvaluateOptions o) {
  usecases::EvaluateRequest& q = o.q;
  const PlotFormat format = parse_plot_format(o.plot_format);
  q.level_sweep = q.level_sweep || !o.html.empty();  // the page is the level sweep's
  const RequestSpelling spelling{{{"probes_hz", "--probes"}, {"levels", "--levels"}}, {{"chain", o.chain}}};
  q.chain = engine::load_chain_file(o.chain);
  q.chain_name = o.chain;
  const std::vector<std::string> presets = models::plant_preset_names();
  if (std::find(presets.begin(), presets.end(), q.plant) == presets.end()) q.plant_config = models::plant_from_name_or_file(q.plant);
  run_use_case([&] { usecases::check(q); }, spelling);
  if (!o.plots.empty() || !o.html.empty()) find_gnuplot();  // before the work, not after it
  BarProgress bar("evaluate");
  const usecases::EvaluateReport report = run_use_case([&] { return usecases::evaluate(q, bar); }, spelling);
  if (report.evaluation) {
    print_table(*report.evaluation);
    std::fprintf(stderr, "(J_c noise floor of the sensor: %.2f %%)\n", report.evaluation->jc_noise_floor_pct);
  }
  if (report.sweep) print_level_sweep(*report.sweep);
  if (report.evaluation && q.attribute) print_attribution(*report.evaluation, report.attribution);
  nlohmann::json result = report.summary;
  result["plots"] = nullptr;
  if (!o.plots.empty() || !o.html.empty()) {
    const std::filesystem::path dir = !o.plots.empty() ? std::filesystem::path(o.plots)
                                                       : std::filesystem::path(o.html + ".figures");
    std::filesystem::create_directories(dir);
    result["plots"] = nlohmann::json::object();
    if (report.evaluation) {
      evaluation::EvaluationOptions shown;
      shown.probe_hz = q.probes_hz;
      result["plots"]["response"] = plot_evaluation_response(*report.evaluation, shown, dir, format).string();
      result["plots"]["harmonics"] = plot_evaluation_harmonics(*report.evaluation, dir, format).string();
    }
    if (report.sweep) {
      const std::filesystem::path chart = plot_level_sweep(*report.sweep, dir, format);
      result["plots"]["thd_vs_level"] = chart.string();
      if (!o.html.empty()) write_sweep_html(o.html, o.chain, report.summary.at("plant"), *report.sweep, chart, format);
    }
  }
  if (!o.out.empty()) models::write_json_file(o.out, result);
  print_result(result);
}

}  // namespace

void register_evaluate(CLI::App& app) {
  auto o = std::make_shared<EvaluateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "evaluate", "Evaluate a controller chain on a simulated transducer: response ripple, THD and J_c ([2C])");
  cmd->add_option("--plant", o->q.plant, "Preset (panel-exciter, linear) or plant JSON file")->capture_default_str();
  cmd->add_option("--chain", o->chain, "Chain file (panelbass chain)")->required();
  cmd->add_option("--probes", o->q.probes_hz, "Probe sine frequencies, Hz (of the table and the level sweep)")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--probe-peak", o->q.probe_peak,
                 "Steady peak of the band-pass + feedforward output at each probe sine (0: the limiter's knee)")
      ->capture_default_str();
  cmd->add_option("--seed", o->q.seed, "Seed of the noise program and the sensor noise")->capture_default_str();
  cmd->add_option("--noise-samples", o->q.noise_samples, "Length of the white-noise record")
      ->capture_default_str();
  cmd->add_flag("--attribute", o->q.attribute,
               "Also evaluate on copies of the plant with one nonlinear term on at a time (every other off): "
               "which physics makes each probe's distortion (\"attribution\" in the result)");
  cmd->add_flag("--level-sweep", o->q.level_sweep,
               "Also sweep the program level at each probe: THD, H2, H3 against the sensor's fundamental, the chain "
               "beside the plant alone at equal output level, and two-tone IMD (\"level_sweep\" in the result; always "
               "run for a chain whose feedforward is a mirror filter, which has no J_c table)");
  cmd->add_option("--levels", o->q.levels, "Program sine amplitudes of the level sweep")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--html", o->html, "Also write the level sweep's THD-versus-level chart and table as an HTML page");
  cmd->add_option("--out", o->out, "Also write the result here (JSON)");
  cmd->add_option("--plot", o->plots, "Directory for the response and harmonics figures (created)");
  cmd->add_option("--plot-format", o->plot_format, "png or svg")->check(CLI::IsMember({"png", "svg"}))->capture_default_str();
  cmd->footer(
      "Examples:\n  panelbass evaluate --plant panel-exciter --chain chain.json --probe-peak 0.6 --out eval.json --plot plots/\n"
      "  panelbass evaluate --plant panel-exciter --chain chain.json --probe-peak 0.6 --attribute   # which term distorts where\n"
      "  panelbass evaluate --plant panel-exciter --chain mirror-chain.json --levels 0.1,0.2,0.4 --html thd.html");
  cmd->callback([o] { run_evaluate(*o); });
}

}  // namespace panelbass::cli

// `panelbass analyze`: the Analysis report of one model on one record (numbers from
// models::analyze_model; figures by gnuplot; an optional self-contained HTML page).

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/gnuplot.h"
#include "cli/html_report.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "cli/report_output.h"
#include "cli/report_plots.h"
#include "models/io/json_file.h"
#include "models/kinds/model_file.h"
#include "models/plant/plant_presets.h"
#include "usecases/analyze.h"

namespace panelbass::cli {
namespace {

namespace fs = std::filesystem;

// The options of `analyze`; the defaults are the request's (usecases::AnalyzeRequest).
struct AnalyzeOptions {
  std::string model, data, plant, history, gain_range;
  DataOptions columns;
  ReportOutputOptions outputs;
  long window = 600;
  usecases::AnalyzeRequest q;  ///< the flags' values (model, record and plant filled in by run_analyze)
};

// KMIN:KMAX → the two gains.
std::vector<double> parse_gain_range(const std::string& text) {
  const auto colon = text.find(':');
  try {
    if (colon == std::string::npos) throw std::invalid_argument("no colon");
    std::size_t used_lo = 0, used_hi = 0;
    const double lo = std::stod(text.substr(0, colon), &used_lo);
    const double hi = std::stod(text.substr(colon + 1), &used_hi);
    if (used_lo != colon || used_hi != text.size() - colon - 1) throw std::invalid_argument("bad numbers");
    return {lo, hi};
  } catch (const std::exception&) {
    throw std::invalid_argument("--gain-range expects KMIN:KMAX with KMIN < KMAX, got \"" + text + "\"");
  }
}

void run_analyze(AnalyzeOptions o) {
  usecases::AnalyzeRequest& q = o.q;
  if (!o.gain_range.empty()) q.gain_range = parse_gain_range(o.gain_range);
  const RequestSpelling spelling{{{"record", "--data"}, {"refine_iterations", "--refine-iter"}, {"frequencies", "--freqs"}},
                                 {{"model", o.model}, {"record", o.data}}};
  run_use_case([&] { usecases::check(q); }, spelling);  // a bad flag before the files are read
  const models::AnyModel model = models::load_model(o.model);
  const dsp::Record data = o.columns.read_at_model_rate(o.data, model.fs());
  q.model = models::read_json_file(o.model);
  q.model_name = o.model;
  q.u = data.columns[0];
  q.y = data.columns[1];
  q.data_name = o.data;
  if (!o.plant.empty()) {
    q.plant = models::plant_from_name_or_file(o.plant);
    q.plant_name = o.plant;
  }
  if (!o.history.empty()) {
    q.history = models::training_history_from_json(models::read_json_file(o.history), o.history);
    if (!q.history) throw std::invalid_argument(o.history + ": no training history (\"history\" or \"meta.history\")");
  }
  // Everything that can be refused is refused before the work starts.
  run_use_case([&] { usecases::check(q); }, spelling);
  const PlotFormat format = o.outputs.prepare();

  BarProgress bar("analyze");
  usecases::ProgressSpan analysis(bar, 0.0, 0.8);
  const usecases::AnalyzeReport report = run_use_case([&] { return usecases::analyze(q, analysis); }, spelling);

  nlohmann::json result = report.summary;
  o.outputs.name_outputs(result);
  ReportPlotOptions plot_options;
  plot_options.format = format;
  plot_options.window = o.window;
  o.outputs.draw_figures(
      "panelbass-analyze", result,
      [&](const fs::path& dir) {
        std::vector<ReportFigure> figures = plot_analysis(report.analysis, dir, plot_options);
        bar.report(0.95, "figures");
        return figures;
      },
      [&](const std::vector<ReportFigure>& figures) { write_html_report(o.outputs.html, result, figures, format); });
  models::write_json_file(o.outputs.out, result);
  bar.report(1.0, "done");
  print_result(result);
}

}  // namespace

void register_analyze(CLI::App& app) {
  auto o = std::make_shared<AnalyzeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "analyze", "Analysis report of a model on data: J, residual tests, spectra, FRF, poles/zeros, root locus, distortion");
  cmd->add_option("--model", o->model, "Model file (JSON, linear or narx)")->required();
  cmd->add_option("--data", o->data, "Data, .csv or .wav")->required();
  o->columns.add_to(cmd);
  cmd->add_option("--init", o->q.init, "Measured outputs given to the model to set its state, then free run")
      ->capture_default_str();
  cmd->add_option("--plant", o->plant, "Plant preset or plant JSON file: harmonic distortion plant vs model, sensor noise floor");
  o->outputs.add_to(cmd, "Report as JSON (the object printed on stdout)", "Self-contained HTML report (figures embedded)");
  cmd->add_option("--lags", o->q.lags, "Lags of the residual correlation tests")->capture_default_str();
  cmd->add_option("--segment", o->q.segment, "Welch segment length (0: a power of 2 up to 4096, N/4)")->capture_default_str();
  cmd->add_option("--window", o->window, "Samples shown in the time plot")->check(CLI::Range(2L, 100000000L))->capture_default_str();
  cmd->add_option("--refine-iter", o->q.refine_iterations,
                  "Linear model without --history: OE iterations from the model on the data for the J figure (0 = none)")
      ->capture_default_str();
  cmd->add_option("--history", o->history, "Training history: JSON with \"history\" (identify narx output) or a model file with meta.history");
  cmd->add_option("--gain-range", o->gain_range, "Root-locus gains KMIN:KMAX in raw units (default: the stable interval around 0 and a little beyond)");
  cmd->add_option("--freqs", o->q.frequencies, "With --plant: stepped-sine frequencies, Hz")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--amplitudes", o->q.amplitudes, "With --plant: drive amplitudes")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--measure", o->q.measure, "With --plant: samples measured per frequency")
      ->capture_default_str();
  cmd->footer(
      "Example:\n"
      "  panelbass simulate --samples 6000 --seed 1 --out run.csv\n"
      "  panelbass identify linear --data run.csv --fs 3000 --method oe --order 8 --out lin.json\n"
      "  panelbass analyze --model lin.json --data run.csv --init 50 --plant panel-exciter \\\n"
      "      --out report.json --html report.html --plots plots/");
  cmd->callback([o] { run_analyze(*o); });
}

}  // namespace panelbass::cli
